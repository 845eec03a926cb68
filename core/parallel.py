"""Row-independent numpy work on every core of the machine.

numpy releases the GIL inside its loops over arrays of more than a few
hundred elements, so threads run them side by side. The steps that work row
by row (a plane fit per data point, a distance per node and neighbour, a
crossing test per triangle pair) are cut into blocks of rows, and the
blocks run on a pool of threads. Each row's result is computed from its row
alone, by the same operations in the same order, so the results are those
of one pass: only the time changes (MLS planes of the 500 m synthetic city
at 1 m: 1.4-1.7 s -> 1.0 s on 2 cores).

The pool has one thread per core, or ``URBANVOX_THREADS`` (Dask workers get
their share of the cores, :mod:`core.workers`).

Work that runs on one core and releases the GIL (a KD-tree build) can also
start early on a thread of its own, :func:`in_background`, while the steps
before the one that needs it run.
"""
from __future__ import annotations

import functools
import os
import threading
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from itertools import islice
from typing import Callable, Iterable, Iterator, Sequence, TypeVar

import numpy as np

from .heap import array_heap_on_pool_thread

T = TypeVar("T")
R = TypeVar("R")

_pools: dict[int, ThreadPoolExecutor] = {}  # by number of threads
_background: ThreadPoolExecutor | None = None
_lock = threading.Lock()
_DONE = object()

#: Blocks per thread of :func:`balanced_blocks`, and the fewest rows of one.
BALANCED_PER_THREAD, BALANCED_ROWS = 4, 1 << 15


def thread_count() -> int:
    """Threads for row blocks: ``URBANVOX_THREADS`` if set, else the cores."""
    try:
        wanted = int(os.environ.get("URBANVOX_THREADS", "0"))
    except ValueError:
        wanted = 0
    return max(1, wanted or _cores())


@functools.cache
def _cores() -> int:
    """The machine's cores, asked once: ``os.cpu_count`` reads a file of the
    system at each call (14 us here), and the pipeline asks for the threads
    some 600 times a run on Delft, 1,000 on the 1 km city."""
    return os.cpu_count() or 1


def map_blocks(func: Callable[[T], R], blocks: Iterable[T]) -> list[R]:
    """``[func(block) for block in blocks]``, the blocks run on the threads.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.arange(10.0)
    >>> np.concatenate(map_blocks(lambda rows: x[rows] ** 2, row_blocks(10, 4))).tolist()[-3:]
    [49.0, 64.0, 81.0]
    """
    blocks = list(blocks)
    if not on_pool(blocks):
        return [func(block) for block in blocks]
    return list(_executor(thread_count()).map(_on_pool(func), blocks))


def map_ahead(func: Callable[[T], R], blocks: Iterable[T]) -> Iterator[R]:
    """``func(block)`` of each block in order, as they are taken: the
    threads work on the next blocks while the caller uses one (writes it
    to a file), up to two per thread ahead of it. A file written a batch of
    blocks at a time, made then written, kept one core idle while it wrote
    (the 1 km city's 510 MB gmsh text: 1.0 s of writing after 1.5 s of
    text).

    Examples
    --------
    >>> list(map_ahead(lambda n: n * n, range(5)))
    [0, 1, 4, 9, 16]
    """
    blocks = list(blocks)
    if not on_pool(blocks):
        yield from (func(block) for block in blocks)
        return
    pool, task = _executor(thread_count()), _on_pool(func)
    waiting = iter(blocks)
    running = deque(pool.submit(task, block) for block in islice(waiting, 2 * thread_count()))
    while running:
        result = running.popleft().result()
        following = next(waiting, _DONE)
        if following is not _DONE:
            running.append(pool.submit(task, following))
        yield result


def in_background(func: Callable[..., R], *args) -> Future:
    """``func(*args)`` started now on a thread of its own; ``.result()`` waits
    for it (and raises what it raised).

    One such thread runs the calls in turn. With one thread
    (``URBANVOX_THREADS=1``) the call runs here, at once.

    Examples
    --------
    >>> in_background(sum, [1, 2, 3]).result()
    6
    """
    global _background
    if thread_count() <= 1:
        future: Future = Future()
        try:
            future.set_result(func(*args))
        except BaseException as exc:  # handed to whoever asks for the result, as a thread would
            future.set_exception(exc)
        return future
    with _lock:
        if _background is None:
            _background = ThreadPoolExecutor(max_workers=1, thread_name_prefix="urbanvox-background")
    return _background.submit(_on_pool(func), *args)


def _on_pool(func: Callable[..., R]) -> Callable[..., R]:
    """``func`` as a task of a pool's thread, which first makes its numpy
    arrays in the array heap if it may (:func:`core.heap.array_heap_on_pool_thread`)."""
    def task(*args):
        array_heap_on_pool_thread()
        return func(*args)

    return task


def on_pool(blocks: Sequence) -> bool:
    """Whether :func:`map_blocks` runs ``blocks`` on the pool's threads (else
    here, one after the other): work inside them that has threads of its own
    (a KD-tree query) then takes one.

    Examples
    --------
    >>> on_pool(row_blocks(10, 10))
    False
    """
    return thread_count() > 1 and len(blocks) > 1


def row_blocks(n: int, size: int) -> list[slice]:
    """Consecutive slices of at most ``size`` rows covering ``range(n)``.

    Examples
    --------
    >>> row_blocks(10, 4)
    [slice(0, 4, None), slice(4, 8, None), slice(8, 10, None)]
    """
    return [slice(start, min(start + size, n)) for start in range(0, n, size)]


def thread_blocks(n: int, most: int | None = None) -> list[slice]:
    """:func:`row_blocks` covering ``range(n)``, one per thread of the pool, or
    more where a block would exceed ``most`` rows: for compiled loops, which
    pay nothing per block and run each on a thread.

    Examples
    --------
    >>> import os
    >>> before = os.environ.get("URBANVOX_THREADS")
    >>> os.environ["URBANVOX_THREADS"] = "2"
    >>> thread_blocks(10), thread_blocks(10, most=3)[:2]
    ([slice(0, 5, None), slice(5, 10, None)], [slice(0, 3, None), slice(3, 6, None)])
    >>> _ = os.environ.pop("URBANVOX_THREADS") if before is None else os.environ.update(URBANVOX_THREADS=before)
    """
    size = max(1, -(-n // thread_count()))
    return row_blocks(n, size if most is None else max(1, min(most, size)))


def balanced_blocks(n: int) -> list[slice]:
    """:func:`thread_blocks` cut finer: about :data:`BALANCED_PER_THREAD`
    blocks per thread, but not under :data:`BALANCED_ROWS` rows (fewer rows:
    as :func:`thread_blocks`, one block per thread). For compiled
    loops over rows that each cost the same, and write only their own rows:
    the threads do not always run alike (another thread's work, the cache),
    and the one done first takes the next block from the pool's queue
    instead of waiting for the other's half. On the 1 km city the quads'
    split quality ran 0.27 s of its 1.05 s with one thread idle, in halves.

    Examples
    --------
    >>> import os
    >>> before = os.environ.get("URBANVOX_THREADS")
    >>> os.environ["URBANVOX_THREADS"] = "2"
    >>> len(balanced_blocks(1_000_000)), balanced_blocks(10) == thread_blocks(10)
    (8, True)
    >>> _ = os.environ.pop("URBANVOX_THREADS") if before is None else os.environ.update(URBANVOX_THREADS=before)
    """
    return thread_blocks(n, max(BALANCED_ROWS, -(-n // (BALANCED_PER_THREAD * thread_count()))))


#: Fewest rows :func:`take_rows` gathers on all cores (fewer: the pool's handoffs cost more).
TAKE_ROWS_PARALLEL = 1 << 18


def take_rows(array: np.ndarray, index: np.ndarray) -> np.ndarray:
    """``array.take(index, axis=0)``, in blocks of ``index`` on all cores for
    a long one: numpy's gather runs without the GIL, and a gather of rows
    scattered over a large table waits on memory, which two cores reach
    faster than one (2 M random rows of a 3 M x 3 table: 62-75 -> 33-40 ms;
    rows in order gain nothing and lose nothing). The same rows, and the
    same error for an index out of range.

    Examples
    --------
    >>> take_rows(np.arange(10.0).reshape(5, 2), np.array([4, 0])).tolist()
    [[8.0, 9.0], [0.0, 1.0]]
    """
    if len(index) < TAKE_ROWS_PARALLEL or thread_count() <= 1:
        return array.take(index, axis=0)
    out = np.empty((len(index),) + array.shape[1:], dtype=array.dtype)

    def gather(rows: slice) -> None:
        # numpy's take into ``out=`` copies through a buffer when it checks
        # the indices (its default): a block's own array, then copied, costs no more.
        out[rows] = array.take(index[rows], axis=0)

    map_blocks(gather, balanced_blocks(len(index)))
    return out


def counted_then_listed(run: Callable[[slice, np.ndarray, int], int], blocks: Sequence[slice]) -> np.ndarray:
    """An int64 list made by a compiled pass over ``blocks`` run twice:
    ``run(block, out, at)`` returns how many entries its block has, writing
    them into ``out`` from ``at`` on unless ``out`` is empty. The first
    round counts, the second writes each block's entries after those of the
    blocks before it, on all cores, in the blocks' order.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.array([3, -1, 4, -1, -5, 9])
    >>> def negative(rows, out, at):
    ...     found = np.flatnonzero(x[rows] < 0) + rows.start
    ...     if len(out):
    ...         out[at:at + len(found)] = found
    ...     return len(found)
    >>> counted_then_listed(negative, row_blocks(6, 4)).tolist()
    [1, 3, 4]
    """
    nothing = np.empty(0, dtype=np.int64)
    counts = map_blocks(lambda block: run(block, nothing, 0), blocks)
    first = np.cumsum([0] + counts)
    out = np.empty(int(first[-1]), dtype=np.int64)
    if len(out):
        map_blocks(lambda job: run(job[0], out, job[1]), list(zip(blocks, first[:-1].tolist())))
    return out


def _executor(threads: int) -> ThreadPoolExecutor:
    """The pool of ``threads`` threads, made once for each count.

    A pool is never shut down: another thread may have it in hand. The
    kernels' preload (:func:`core.jit.preload`) warmed them up on the pool of
    the cores while a test asked for three threads, whose new pool shut the
    other down under the preload ("cannot schedule new futures after
    shutdown"). A process sees one or two counts.
    """
    with _lock:
        pool = _pools.get(threads)
        if pool is None:
            pool = _pools[threads] = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="urbanvox")
        return pool
