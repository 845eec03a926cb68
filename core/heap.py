"""How a run gets its memory: freed memory reused, no huge-page requests (Linux).

glibc's ``malloc`` serves every block above its mmap threshold (128 kB,
raised at run time to at most 32 MB) with fresh pages from the kernel and
returns them on ``free``. The pipeline's numpy temporaries are tens to
hundreds of MB, so each step faults in and zeroes its memory again: on the
500 m synthetic city at 1 m voxels that is 3.5 s of the kernel's time in a
16 s run. With a high mmap threshold they come from the heap and reuse what
the last step freed (14 s, 1.4 s in the kernel, the same peak memory; the
2 km city in 25 tiles: 350 s -> 250 s, its peak 6.8 -> 7.5 GB, as freed
blocks of one size do not always fit the next request).

numpy also asks the kernel for transparent huge pages on every array above
4 MB (``madvise``); where the kernel then compacts memory on the spot to
find them (``defrag`` set to ``madvise``, a common default) that cost the
500 m city another 1.2 s of kernel time and 1.3 s in all (12.0 -> 10.7 s).

:func:`reusing_freed_memory` raises the thresholds and turns numpy's
huge-page requests off while a reconstruction runs. When the last run ends,
the heap is kept for the next run for :func:`keep_seconds` (a minute by
default): QGIS's batch runs, a model's chain and parameters tuned again run
one after the other, and each run would otherwise fault its memory in again
(the 1 km city at 1 m: 570 k page faults, 2.8 s of the kernel's time per
run). Then it hands the freed memory back (``malloc_trim``) and restores
glibc's fixed defaults and numpy's setting, so that QGIS does not keep the
run's peak while it is idle.
:data:`WORKER_ENVIRONMENT` does the same for worker processes (Dask), where
the settings must be in place before the first allocation; one arena makes
the tasks' threads use that heap too (a thread's own arena serves blocks
above 64 MB from mmap whatever the threshold). In a host process (QGIS),
whose threads have arenas of their own, the run's thread and the pool's make
numpy's arrays in a region of their own instead (:mod:`core.array_heap`), in
runs large enough for the compiled kernels.

A fresh process still faults in every page of its heap once, and on a
virtual machine each fault costs the host's time too: 0.39 M faults and 1-5 s
of the kernel's time in the 1 km city's first run (as the host's state
varied within an hour), 0.1 s in a later one.
:func:`fault_in_ahead` has a thread of lower priority fault in, while the
run's first steps go on, the memory the run's estimate says it will need,
where a core is idle (1.7 of the 2 are busy on average).
Elsewhere than Linux and glibc all of it does nothing.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys
import threading
from contextlib import contextmanager
from typing import Iterator

import numpy as np

#: mallopt parameters (malloc.h) and glibc's defaults.
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD, _M_ARENA_MAX = -1, -3, -8
_DEFAULT_TRIM, _DEFAULT_MMAP = 128 * 1024, 128 * 1024
#: Largest value mallopt takes (a C int); larger blocks still come from mmap.
_HIGH = 2**31 - 1
#: Trim threshold that never trims (mallopt(3)). _HIGH would not do: when a
#: step frees more than 2 GB at the top of the heap (the 2 km city's tile
#: merge frees 2.4 GB) glibc hands it all back, and the next step faults it
#: in again (617 k page faults, 2 of the merge's 4 s).
_NEVER = -1

#: Environment for worker processes: the same settings, from their start.
WORKER_ENVIRONMENT = {
    "MALLOC_MMAP_THRESHOLD_": str(_HIGH),
    "MALLOC_TRIM_THRESHOLD_": str(_NEVER),
    "MALLOC_ARENA_MAX": "1",
    "NUMPY_MADVISE_HUGEPAGE": "0",
}

#: Blocks from this size up come from fresh pages in a thread's own glibc heap
#: (its largest mmap threshold): a run whose estimate reaches it takes the
#: array heap in a host's thread (:func:`use_array_heap_here`).
THREAD_HEAP_FRESH = 64 << 20

#: Seconds the heap is kept after the last run ends (:func:`keep_seconds`).
KEEP_SECONDS = 60.0

#: madvise(2) advice: fault pages in as a write would, without writing (Linux 5.14).
_MADV_POPULATE_WRITE = 23
#: Bytes faulted in per call (:func:`fault_in_ahead`). Each call holds the
#: process's memory-map lock, which the run's own faults and mappings may
#: wait for: calls of 16 MB held the 1 km city's ground level up 2 s.
_AHEAD_STEP = 1 << 20
#: Niceness of the thread that faults pages in ahead: the run's threads come
#: first where both cores are busy (1.6 GB ahead of a first run of the 1 km
#: city, three in turn: nice 5 12.4-12.8 s of method, nice 19 12.6-12.9 s,
#: none ahead 15.0-19.6 s).
_AHEAD_NICE = 5
#: Less than this to fault in is not worth a thread.
_AHEAD_MIN = 16 << 20
#: Largest block asked of malloc at once (its mmap threshold is a C int).
_AHEAD_PIECE = 1 << 30

_lock = threading.Lock()
_one_heap = os.environ.get("MALLOC_ARENA_MAX", "").strip() == "1"  # every thread on the first heap
_depth = 0
_applied = False  # the run's settings in place (during runs and the time kept after)
_huge_pages: bool | None = None  # numpy's setting before the first run
_release_timer: threading.Timer | None = None
_ahead: threading.Thread | None = None  # the thread of fault_in_ahead, while it runs
_ahead_stop = threading.Event()
#: glibc's free bytes just after the last malloc_trim (:func:`give_back`): they hold no pages.
_free_handed_back = 0


def _glibc() -> ctypes.CDLL | None:
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        libc.mallopt, libc.malloc_trim  # noqa: B018 (musl has neither)
    except (OSError, AttributeError):
        return None
    return libc


_LIBC = _glibc()
if _LIBC is not None:
    _LIBC.malloc.restype, _LIBC.malloc.argtypes = ctypes.c_void_p, [ctypes.c_size_t]
    _LIBC.free.restype, _LIBC.free.argtypes = None, [ctypes.c_void_p]
    _LIBC.madvise.restype, _LIBC.madvise.argtypes = ctypes.c_int, [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int]


class _MallInfo2(ctypes.Structure):
    """glibc's ``struct mallinfo2`` (2.33 and later): the arena's sizes in bytes."""
    _fields_ = [(name, ctypes.c_size_t) for name in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks",
                                                      "fsmblks", "uordblks", "fordblks", "keepcost")]


#: glibc's mallinfo2, or None (a C library too old to say what its heap holds free).
_MALLINFO2 = getattr(_LIBC, "mallinfo2", None)
if _MALLINFO2 is not None:
    _MALLINFO2.restype = _MallInfo2


def numpy_core():
    """numpy's core package: ``np._core`` (numpy 2), else ``np.core`` (None in neither)."""
    return getattr(np, "_core", None) or getattr(np, "core", None)


def _set_huge_pages(enabled: bool) -> bool | None:
    """Turn numpy's huge-page requests on or off; the previous setting (None: not available)."""
    multiarray = getattr(numpy_core(), "multiarray", None)
    setter = getattr(multiarray, "_set_madvise_hugepage", None)
    return None if setter is None else bool(setter(enabled))


def one_arena() -> bool:
    """Make every thread of this process allocate from one heap, as
    :data:`WORKER_ENVIRONMENT` does for workers: for a process of its own
    (the command line, the benchmarks), called before it starts threads.

    glibc gives threads arenas of their own, and a thread's arena serves
    blocks above 64 MB from fresh pages whatever :func:`reusing_freed_memory`
    sets; numpy's large temporaries made on the row-block pool's threads
    (:mod:`core.parallel`) and in scipy's query threads then fault their
    memory in again at every step. glibc fixes the number of arenas when a
    thread first needs one, so this is too late once threads have run; a
    host process (QGIS) keeps its own policy. Returns whether it was set
    (glibc only; ``tests/test_heap.py`` counts the page faults it saves).
    """
    global _one_heap
    _one_heap = _one_heap or (_LIBC is not None and bool(_LIBC.mallopt(_M_ARENA_MAX, 1)))
    return _one_heap


def host_threads() -> bool:
    """Whether this process's threads may have arenas of their own (a host
    such as QGIS, or a process that did not call :func:`one_arena` before its
    threads): the runs' threads then make numpy's arrays in
    :mod:`core.array_heap`."""
    return _LIBC is not None and not _one_heap


def use_array_heap_here(load: bool = False) -> bool:
    """In a host process, this thread's numpy arrays from :mod:`core.array_heap`
    from now on; whether they do. A run's thread asks as the run starts, the
    threads of :mod:`core.parallel`'s pools before each of their tasks (they
    run the runs' blocks only, :func:`array_heap_on_pool_thread`). Never
    raises: glibc serving a thread as before is no reason to stop a run, or
    to break a pool.

    Only once numba is imported, by the kernels of a run large enough to
    want them (:func:`core.jit.kernels`), or with ``load`` during a run (a
    reader about to make a large run's points, :mod:`core.readers.las`):
    the region's allocator is compiled with numba, and importing it for a
    small run cost more than the region gains there (Delft at 1 m through
    ``qgis_process``, five pairs in turn: 2.49-3.24 s a run with it,
    1.92-2.57 s without). A run too small for the kernels makes no array as large as a
    thread's heap serves from fresh pages (64 MB). The run's
    :func:`reusing_freed_memory` ends the thread's uses made inside it.
    """
    if not _region_allowed(load):
        return False
    try:
        from . import array_heap

        return array_heap.use_on_this_thread()
    except Exception:  # noqa: BLE001 - an unexpected numpy: glibc serves, as before
        return False


def _region_allowed(load: bool = False) -> bool:
    """Whether :func:`use_array_heap_here` may take the region here (see there)."""
    return host_threads() and ("numba" in sys.modules or (load and _depth > 0))


def array_heap_on_pool_thread() -> None:
    """On a pool's thread, before a task: the region from now on
    (:func:`use_array_heap_here`) if this thread does not use it yet and may;
    numba may have come since the thread started."""
    if _region_allowed():
        from . import array_heap

        if not array_heap.in_use_here():
            use_array_heap_here()


def keep_seconds() -> float:
    """How long the heap is kept for the next run after the last one ends:
    ``URBANVOX_KEEP_MEMORY_SECONDS`` if set, else :data:`KEEP_SECONDS`; 0
    hands it back as the run ends.

    Examples
    --------
    >>> import os
    >>> name = "URBANVOX_KEEP_MEMORY_SECONDS"
    >>> before = os.environ.get(name)
    >>> os.environ[name] = "0"
    >>> keep_seconds()
    0.0
    >>> _ = os.environ.pop(name) if before is None else os.environ.update({name: before})
    """
    text = os.environ.get("URBANVOX_KEEP_MEMORY_SECONDS", "").strip()
    try:
        return max(0.0, float(text)) if text else KEEP_SECONDS
    except ValueError:
        return KEEP_SECONDS


@contextmanager
def reusing_freed_memory() -> Iterator[None]:
    """Keep freed memory for reuse inside the block, and for the next block
    for :func:`keep_seconds` after; give it back then (:func:`release`).

    Nested and concurrent uses are counted: the settings change when the
    first one enters and are restored when the last one has left and none
    entered for :func:`keep_seconds`.

    Examples
    --------
    >>> import numpy as np
    >>> with reusing_freed_memory():
    ...     total = sum(float(np.ones(5_000_000).sum()) for _ in range(3))
    >>> total
    15000000.0
    """
    global _depth, _applied, _huge_pages, _release_timer
    if _LIBC is None:
        yield
        return
    from . import array_heap

    uses_before = array_heap.uses_here()
    use_array_heap_here()
    with _lock:
        _depth += 1
        if _release_timer is not None:  # a run within the time kept: the heap serves it
            _release_timer.cancel()
            _release_timer = None
        if not _applied:
            _LIBC.mallopt(_M_MMAP_THRESHOLD, _HIGH)
            _LIBC.mallopt(_M_TRIM_THRESHOLD, _NEVER)
            _huge_pages = _set_huge_pages(False)
            _applied = True
    try:
        yield
    finally:
        while array_heap.uses_here() > uses_before:  # the block's own, at its start and later
            array_heap.stop_on_this_thread()
        with _lock:
            _depth -= 1
            if _depth == 0:  # what is not faulted in yet waits for the next run's own needs
                _ahead_stop.set()
            wait = keep_seconds() if _depth == 0 else None
            if wait:
                _release_timer = threading.Timer(wait, release)
                _release_timer.daemon = True  # never keeps a process alive
                _release_timer.start()
        if wait == 0.0:
            release()


def release() -> None:
    """Restore glibc's defaults and numpy's huge-page setting and hand the
    heap's free memory back, unless a run is going on (then its end does).

    Called when the heap has been kept for :func:`keep_seconds` after the
    last run; a host may call it sooner.
    """
    global _applied, _release_timer
    if _LIBC is None:
        return
    with _lock:
        if _depth > 0 or not _applied:
            return
        if _release_timer is not None and _release_timer is not threading.current_thread():
            _release_timer.cancel()
        _release_timer = None
        _LIBC.mallopt(_M_MMAP_THRESHOLD, _DEFAULT_MMAP)
        _LIBC.mallopt(_M_TRIM_THRESHOLD, _DEFAULT_TRIM)
        if _huge_pages is not None:
            _set_huge_pages(_huge_pages)
        _applied = False
        if _ahead is not None:  # stopped as the last run ended: at most one step left
            _ahead.join()
        give_back()
        if host_threads():
            from . import array_heap

            array_heap.return_free_pages()


def give_back() -> None:
    """Hand the heap's free memory back to the kernel now, inside a run.

    For a step that will not need it soon: the tiled run's own process,
    once its points are read and sorted, only waits for the workers' pieces
    while they run (see :func:`core.tiles.reconstruct_tiled`).
    """
    global _free_handed_back
    if _LIBC is not None:
        _LIBC.malloc_trim(0)
        # The free chunks stay in glibc's count with no pages behind them.
        _free_handed_back = _MALLINFO2().fordblks if _MALLINFO2 is not None else 0


def held_free_bytes() -> int:
    """Bytes of memory this process holds free for its next arrays, in its
    pages: what the memory guard may count beside the system's
    ``MemAvailable``, which leaves them out.

    During a run and for :func:`keep_seconds` after, glibc's heap and
    :mod:`core.array_heap` keep what the run frees (and what
    :func:`fault_in_ahead` faulted in): the next step's or the next run's
    arrays take it without the system giving any. Without counting it, a
    guard asked within that time (the surfaces' check after the voxel
    stages freed gigabytes, a batch's next run) saw that memory as taken.

    Two figures each hold at least that memory, and the smaller is taken:
    the heaps' own count of their free bytes beyond what they held free when
    they last handed their pages back (those are in ``MemAvailable``
    already; free memory faulted in again since is then left out, on the
    safe side), and the process's anonymous resident memory less what the
    heaps' live blocks take (which also counts Python's own small-object
    arenas and other libraries' mappings). 0 where glibc cannot say (before
    2.33, or another C library).

    Examples
    --------
    >>> held_free_bytes() >= 0
    True
    """
    if _MALLINFO2 is None:
        return 0
    from . import array_heap

    info = _MALLINFO2()
    region_free, region_live = array_heap.free_held()
    counted = max(0, info.fordblks - _free_handed_back) + region_free
    resident = (proc_bytes("/proc/self/status", "RssAnon") or 0) - (info.uordblks + info.hblkhd + region_live)
    return int(max(0, min(counted, resident)))


def proc_bytes(path: str, key: str) -> int | None:
    """A ``key:  N kB`` line of a Linux ``/proc`` file (``/proc/meminfo``,
    ``/proc/self/status``) in bytes; None where there is none.

    Examples
    --------
    >>> proc_bytes("/no/such/file", "MemAvailable") is None
    True
    """
    try:
        with open(path, encoding="ascii") as lines:
            for line in lines:
                if line.startswith(key + ":"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def fault_in_ahead(nbytes: int) -> threading.Thread | None:
    """Fault in the pages of the ``nbytes`` a run is about to need that its
    heap does not hold free yet, on a thread of lower priority, while the
    run goes on; the thread, or None where nothing is to do.

    The heap is grown first (the command line's: one block of the C
    library's heap, freed again at once; a host's: the range above the top
    of :mod:`core.array_heap`'s region), then the thread faults its pages in
    a step at a time without writing them (``MADV_POPULATE_WRITE``), so
    that the run's arrays, which take that memory as they come, are not
    changed by it. It stops at the end of the last run, and where the
    kernel cannot (before Linux 5.14). Only during a run
    (:func:`reusing_freed_memory`) and where the heap keeps what it frees;
    ``URBANVOX_FAULT_AHEAD=0`` turns it off.

    On the 1 km city at 1 m (the grid's estimate: 1.3 GB, some 0.8 GB
    beyond what the reading left free), a process's first run took 12.3-13.1
    s of method against 13.3-14.8 s without (six pairs, in turn); the
    benchmark's first runs, three pairs each, 13.1-14.9 s end to end against
    14.9-15.7 s in QGIS's way, 14.1-15.5 s against 14.2-15.1 s (no clear
    gain) on the command line's. The gain follows the host's cost of a fault.
    Later runs, whose heap holds the memory, do not start it.
    """
    global _ahead
    if _LIBC is None or _depth == 0 or os.environ.get("URBANVOX_FAULT_AHEAD", "1").strip() == "0":
        return None
    with _lock:
        if _ahead is not None and _ahead.is_alive():
            return None
        ranges = _ranges_ahead(int(nbytes))
        if not ranges:
            return None
        _ahead_stop.clear()
        _ahead = threading.Thread(target=_fault_in, args=(ranges,), name="urbanvox-pages", daemon=True)
    _ahead.start()
    return _ahead


def _ranges_ahead(nbytes: int) -> list[tuple[int, int]]:
    """The address ranges that the next ``nbytes`` of this thread's arrays
    will take beyond the free memory its heap holds, the heap grown to them."""
    from . import array_heap

    if array_heap.in_use_here():
        return array_heap.ahead_of_top(nbytes, _AHEAD_MIN)
    if not _one_heap or _MALLINFO2 is None:  # another arena's heap, or a C library too old to say
        return []
    want = nbytes - _MALLINFO2().fordblks
    if want < _AHEAD_MIN:
        return []
    blocks = []
    while want > 0:
        size = min(want, _AHEAD_PIECE)
        address = _LIBC.malloc(size)
        if not address:
            break
        blocks.append((address, size))
        want -= size
    for address, _ in blocks:  # the heap keeps them: its top does not shrink during runs
        _LIBC.free(address)
    page = os.sysconf("SC_PAGE_SIZE")
    return [(-(-address // page) * page, size // page * page - page) for address, size in blocks]


def _fault_in(ranges: list[tuple[int, int]]) -> None:
    try:  # Linux: the niceness of this thread only
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), _AHEAD_NICE)
    except (AttributeError, OSError):
        pass
    for address, size in ranges:
        for offset in range(0, size, _AHEAD_STEP):
            if _ahead_stop.is_set() or _LIBC.madvise(address + offset, min(_AHEAD_STEP, size - offset),
                                                     _MADV_POPULATE_WRITE) != 0:
                return
