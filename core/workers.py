"""Where tiles run: one after the other in this process, or on Dask workers.

:class:`TileRunner` takes ``(tile index, window)`` pairs, makes each tile's
job only when it is sent (its points cropped to the window), keeps at most
two jobs per worker in flight, and yields the pieces as they finish, with
progress and cancel. A local cluster is a Dask ``LocalCluster`` of worker
processes started with this Python (inside QGIS, ``sys.executable`` is not
it); any scheduler address is accepted instead.
"""
from __future__ import annotations

import logging
import os
import shutil
import sys
import warnings
from contextlib import contextmanager
from typing import TYPE_CHECKING, Callable, Iterator, Sequence

from .errors import Cancelled, UrbanvoxError
from .heap import WORKER_ENVIRONMENT
from .progress import Text

if TYPE_CHECKING:
    from .tiles import Columns, TileJob, TileOptions, TilePiece


class TileRunner:
    """Runs tiles in this process or on Dask, yielding pieces as they finish.

    Work is a queue of ``(tile index, window)``; a tile's job (its points
    cropped to the window) is made only when it is sent, and at most two
    per worker are in flight, so the copies of the points stay few.
    """

    def __init__(self, options: "TileOptions", make_job: "Callable[[int, Columns], TileJob]",
                 run_tile: "Callable[..., TilePiece]"):
        self.options = options
        self.make_job = make_job
        self.run_tile = run_tile  # a module-level function: Dask pickles it by name
        self.client = None
        self.cluster = None
        self.queue: "list[tuple[int, Columns]]" = []
        self.futures: list = []
        self.in_flight = 1

    def __enter__(self) -> "TileRunner":
        o = self.options
        if o.scheduler or (o.workers or 0) > 1:
            try:
                from dask.distributed import Client, LocalCluster
            except ImportError as exc:
                raise UrbanvoxError(
                    "Tiles on several workers need Dask: "
                    f"{_python()} -m pip install 'dask[distributed]' (or set the workers to 0).") from exc
            if o.scheduler:
                self.client = Client(o.scheduler)
            else:
                _use_python_for_workers()
                with _worker_environment(int(o.workers)):
                    # silence_logs: a cancelled tile makes a worker log a warning per task.
                    self.cluster = LocalCluster(n_workers=int(o.workers), threads_per_worker=1,
                                                processes=True, dashboard_address=None,
                                                silence_logs=logging.ERROR)
                self.client = Client(self.cluster)
            self.in_flight = 2 * max(1, len(self.client.scheduler_info().get("workers", {})) or int(o.workers or 1))
        return self

    def __exit__(self, *exc) -> None:
        for future in self.futures:
            future.cancel()
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()

    def submit(self, index: int, window: "Columns") -> None:
        self.queue.append((index, window))

    def _send(self) -> None:
        while self.queue and len(self.futures) < self.in_flight:
            job = self.make_job(*self.queue.pop(0))
            # A tile's points travel with its task, by design: made when sent,
            # a few in flight. Dask warns of every task above 10 MB (a 500 m
            # tile of 10 points/m² is 80 MB), which would only be noise here.
            with warnings.catch_warnings():
                warnings.filterwarnings("ignore", message="Sending large graph", category=UserWarning)
                self.futures.append(self.client.submit(self.run_tile, job, pure=False))

    def run(self, is_cancelled, progress, shares: "Sequence[float]"):
        """Run the tiles queued; yield their pieces as they finish. The
        progress bar goes by ``shares``, each tile's share of the work, by
        index (a tile's own steps move it when the tile runs here)."""
        total = len(shares)
        finished, done = 0, 0.0
        while self.queue or self.futures:
            if is_cancelled is not None and is_cancelled():
                raise Cancelled()
            if self.client is None:
                job = self.make_job(*self.queue.pop(0))

                def tile_progress(fraction: float, message: str, start: float = done, share: float = shares[job.index],
                                  n: int = finished + 1) -> None:
                    if progress is not None:
                        progress(start + share * fraction, Text("Tile {}/{}: {}", n, total, message))

                piece = self.run_tile(job, tile_progress, is_cancelled)
                del job
            else:
                from dask.distributed import wait

                self._send()
                try:  # short waits, so that a cancel is seen
                    ready = wait(self.futures, timeout=0.5, return_when="FIRST_COMPLETED").done
                except TimeoutError:
                    continue
                future = next(iter(ready))
                self.futures.remove(future)
                piece = future.result()
            if piece.grow is None:
                finished += 1
                done += shares[piece.index]
                if progress is not None:
                    progress(done, Text("Tile {}/{} done", finished, total))
            yield piece


def _python() -> str:
    """The Python interpreter to run workers with: this Python's own.

    Inside QGIS ``sys.executable`` is not the interpreter QGIS embeds (it is
    QGIS, or whatever ``python3`` comes first on PATH), so the interpreter of
    ``sys.exec_prefix`` and this version is preferred.
    """
    version = f"python{sys.version_info[0]}.{sys.version_info[1]}"
    for candidate in (os.path.join(sys.exec_prefix, "bin", version),
                      os.path.join(sys.base_exec_prefix, "bin", version)):
        if os.access(candidate, os.X_OK):
            return candidate
    return sys.executable or shutil.which("python3") or "python3"


def _use_python_for_workers() -> None:
    """Spawn Dask's worker processes with this Python (see :func:`_python`)."""
    import multiprocessing

    multiprocessing.set_executable(_python())


@contextmanager
def _worker_environment(workers: int) -> Iterator[None]:
    """Start local workers with the allocator settings of :mod:`core.heap`
    and their share of the cores for row blocks (:mod:`core.parallel`).

    Dask's nannies put their ``pre-spawn-environ`` into this process's
    environment before spawning a worker (its ``MALLOC_TRIM_THRESHOLD_`` of
    64 kB would hand every freed temporary back to the kernel); ours replace
    them, and this process's environment (QGIS's) is put back afterwards.
    """
    import dask

    share = {"URBANVOX_THREADS": str(max(1, (os.cpu_count() or 1) // max(1, workers)))}
    environ = {**dask.config.get("distributed.nanny.pre-spawn-environ", default={}), **WORKER_ENVIRONMENT,
               **share}
    saved = {name: os.environ.get(name) for name in environ}
    try:
        with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}):
            yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
