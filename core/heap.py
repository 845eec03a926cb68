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
numpy's arrays in a region of their own instead (:mod:`core.array_heap`).
Elsewhere than Linux and glibc both do nothing.
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

#: Seconds the heap is kept after the last run ends (:func:`keep_seconds`).
KEEP_SECONDS = 60.0

_lock = threading.Lock()
_one_heap = os.environ.get("MALLOC_ARENA_MAX", "").strip() == "1"  # every thread on the first heap
_depth = 0
_applied = False  # the run's settings in place (during runs and the time kept after)
_huge_pages: bool | None = None  # numpy's setting before the first run
_release_timer: threading.Timer | None = None


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


def _set_huge_pages(enabled: bool) -> bool | None:
    """Turn numpy's huge-page requests on or off; the previous setting (None: not available)."""
    multiarray = getattr(getattr(np, "_core", None) or getattr(np, "core", None), "multiarray", None)
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


def use_array_heap_here() -> bool:
    """In a host process, this thread's numpy arrays from :mod:`core.array_heap`
    from now on; whether they do. A run's thread asks as the run starts, the
    threads of :mod:`core.parallel`'s pools as they start (they run the runs'
    blocks only). Never raises: glibc serving a thread as before is no reason
    to stop a run, or to break a pool at a thread's start."""
    if not host_threads():
        return False
    try:
        from . import array_heap

        return array_heap.use_on_this_thread()
    except Exception:  # noqa: BLE001 - an unexpected numpy: glibc serves, as before
        return False


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
    on_region = use_array_heap_here()
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
        if on_region:
            from . import array_heap

            array_heap.stop_on_this_thread()
        with _lock:
            _depth -= 1
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
    if _LIBC is not None:
        _LIBC.malloc_trim(0)
