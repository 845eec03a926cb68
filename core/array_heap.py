"""numpy's large arrays from one reused region, for runs on a host's threads (Linux).

:mod:`core.heap` has glibc keep the memory a run frees, so that the next
step reuses it instead of faulting in fresh pages. That holds for the heap
of the process's first thread, and for every thread when the process is the
run's own (:func:`core.heap.one_arena`: the command line, the benchmarks,
Dask workers). QGIS runs an algorithm on a thread of its task pool, and
glibc gave that thread an arena of its own before the plugin loaded: there
every block above 64 MB comes from fresh pages and goes back when freed,
and emptied heaps go back too. On the 1 km synthetic city that was 1.4-1.6 M
page faults a run, 13.4-15.3 s of method against 10.8-11.6 s.

numpy lets a thread choose the allocator of its arrays' data (NEP 49,
``PyDataMem_SetHandler``, a context variable: other threads and the host's
code keep theirs). :func:`use_on_this_thread` sets one whose blocks of 1 MB
and more come from a region of address space reserved once, best fit with
freed ranges merged (:mod:`core.array_heap_kernel`, compiled with numba),
the smaller ones from glibc. :func:`return_free_pages` hands the free
ranges' pages back; :mod:`core.heap` calls it when it hands back its own.
numba's own arrays, and other libraries' buffers, still come from glibc.

It is off (:func:`available` is False) without numba, off Linux and glibc, where the
numpy headers do not give the handler's place in numpy's C API, where the
region cannot be reserved, and with ``URBANVOX_ARRAY_HEAP=0``.
"""
from __future__ import annotations

import ctypes
import os
import re
import sys
import threading
from pathlib import Path

import numpy as np

from . import jit
from .heap import _glibc, numpy_core

_lock = threading.Lock()
_local = threading.local()
_state: np.ndarray | None = None
_kernel = None  # core.array_heap_kernel, once the handler is made
_capsule = None
_set_handler = None
_tried = False
_keep: list = []  # what numpy's handler points into: the struct and its name
_free_handed_back = 0  # bytes of the free ranges when their pages were last handed back


class _Allocator(ctypes.Structure):
    _fields_ = [("ctx", ctypes.c_size_t), ("malloc", ctypes.c_size_t), ("calloc", ctypes.c_size_t),
                ("realloc", ctypes.c_size_t), ("free", ctypes.c_size_t)]


class _Handler(ctypes.Structure):
    """numpy's ``PyDataMem_Handler``, version 1."""
    _fields_ = [("name", ctypes.c_char * 127), ("version", ctypes.c_uint8), ("allocator", _Allocator)]


def _api_index(name: str) -> int | None:
    """The place of ``name`` in numpy's C API table, read from numpy's own header."""
    include = Path(np.get_include()) / "numpy" / "__multiarray_api.h"
    try:
        text = include.read_text()
    except OSError:
        return None
    found = re.search(r"#define " + name + r"\s*\\\s*\(\*\(PyObject \* \(\*\)\(PyObject \*\)\)\s*\\\s*"
                      r"PyArray_API\[(\d+)\]\)", text)
    return int(found.group(1)) if found else None


def _api_capsule():
    core = numpy_core()
    return getattr(core, "_multiarray_umath", None) and core._multiarray_umath._ARRAY_API


def _prepare() -> bool:
    """Make the handler once: False if it cannot be made here."""
    global _state, _kernel, _capsule, _set_handler, _tried
    with _lock:
        if _tried:
            return _capsule is not None
        _tried = True
        if not sys.platform.startswith("linux") or os.environ.get("URBANVOX_ARRAY_HEAP", "1").strip() == "0":
            return False
        index = _api_index("PyDataMem_SetHandler")
        libc = _glibc()
        kernel = jit.kernels("array_heap_kernel")
        if index is None or libc is None or kernel is None:
            return False
        try:
            pythonapi = ctypes.pythonapi
            pythonapi.PyCapsule_GetPointer.restype = ctypes.c_void_p
            pythonapi.PyCapsule_GetPointer.argtypes = [ctypes.py_object, ctypes.c_char_p]
            pythonapi.PyCapsule_New.restype = ctypes.py_object
            pythonapi.PyCapsule_New.argtypes = [ctypes.c_void_p, ctypes.c_char_p, ctypes.c_void_p]
            table = ctypes.cast(pythonapi.PyCapsule_GetPointer(_api_capsule(), None),
                                ctypes.POINTER(ctypes.c_void_p))
            set_handler = ctypes.PYFUNCTYPE(ctypes.py_object, ctypes.py_object)(table[index])
            size = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
            mmap = libc.mmap
            mmap.restype = ctypes.c_size_t
            mmap.argtypes = [ctypes.c_size_t, ctypes.c_size_t, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                             ctypes.c_ssize_t]
            # Address space only: pages are backed as the arrays touch them.
            base = mmap(0, size, 0x1 | 0x2, 0x02 | 0x20 | 0x4000, -1, 0)  # read/write, private anonymous, noreserve
            if base in (0, 2**64 - 1):
                return False
            state = kernel.new_state(base, size)
            handler = _Handler(b"urbanvox_array_heap", 1,
                               _Allocator(state.ctypes.data, kernel.array_malloc.address, kernel.array_calloc.address,
                                          kernel.array_realloc.address, kernel.array_free.address))
            name = b"mem_handler"
            capsule = pythonapi.PyCapsule_New(ctypes.addressof(handler), name, None)
        except Exception as exc:  # an unexpected numpy or libc: glibc's allocator stays
            jit._warn("array_heap_kernel", exc)
            return False
        _keep.extend([handler, name])
        _state, _kernel, _capsule, _set_handler = state, kernel, capsule, set_handler
        return True


def available() -> bool:
    """Whether this process can use the handler (made at the first call).

    Examples
    --------
    >>> isinstance(available(), bool)
    True
    """
    return _prepare()


def use_on_this_thread() -> bool:
    """Make the arrays of this thread's later allocations come from the
    region; whether they do. Counted per thread: :func:`stop_on_this_thread`
    restores the thread's own allocator when its last use ends."""
    if not _prepare():
        return False
    depth = getattr(_local, "depth", 0)
    if depth == 0:
        _local.previous = _set_handler(_capsule)
    _local.depth = depth + 1
    return True


def stop_on_this_thread() -> None:
    """End a :func:`use_on_this_thread` of this thread. Arrays made in the
    meantime keep their allocator (numpy stores it in each array)."""
    depth = getattr(_local, "depth", 0)
    if depth == 0:
        return
    _local.depth = depth - 1
    if depth == 1:
        _set_handler(_local.previous)
        _local.previous = None


def uses_here() -> int:
    """This thread's :func:`use_on_this_thread` not ended yet."""
    return getattr(_local, "depth", 0)


def in_use_here() -> bool:
    """Whether this thread's new arrays come from the region.

    Examples
    --------
    >>> in_use_here()
    False
    """
    return getattr(_local, "depth", 0) > 0


def return_free_pages() -> int:
    """Hand the pages of the region's free ranges back to the system; the bytes."""
    global _free_handed_back
    if _state is None:
        return 0
    returned = _kernel.return_free_pages(_state)
    _free_handed_back = sum(free_sizes())  # listed still, with no pages behind them
    return returned


def free_sizes() -> list[int]:
    """Bytes of each of the region's free ranges (for tests and benchmarks)."""
    if _state is None:
        return []
    first, count = _kernel.FIRST, int(_state[_kernel.COUNT])
    return _state[first + 1:first + 2 * count:2].tolist()


def region_in_use() -> tuple[int, int]:
    """Bytes of the region below its top, and in its free ranges (for tests and benchmarks)."""
    if _state is None:
        return 0, 0
    return int(_state[_kernel.TOP]), sum(free_sizes())


def free_held() -> tuple[int, int]:
    """Bytes the region holds free in pages (its free ranges beyond those
    handed back, and the pages faulted in above its top), and bytes its
    arrays take (below its top, less the free ranges):
    :func:`core.heap.held_free_bytes`."""
    if _state is None:
        return 0, 0
    top, free = region_in_use()
    # The ranges free when the pages were last handed back have none (some
    # faulted in again since are left out, on the safe side).
    return max(0, free - _free_handed_back) + max(0, int(_state[_kernel.HIGH]) - top), top - free


def ahead_of_top(nbytes: int, least: int) -> list[tuple[int, int]]:
    """The range above the region's high-water mark that ``nbytes`` more of
    arrays would reach beyond the free memory the region holds, if
    ``least`` bytes or more: pages to fault in ahead (:func:`core.heap.fault_in_ahead`),
    counted under the mark so that :func:`return_free_pages` hands them back."""
    if _state is None:
        return []
    top, high, size = int(_state[_kernel.TOP]), int(_state[_kernel.HIGH]), int(_state[_kernel.SIZE])
    end = min(top + nbytes - region_in_use()[1], size) // _kernel.PAGE * _kernel.PAGE  # free ranges serve first
    if end - high < least:
        return []
    _state[_kernel.HIGH] = end  # the allocator, called with the GIL held as this is, moves it too
    return [(int(_state[_kernel.BASE]) + high, end - high)]
