"""Compiled cells of a mesh's sample points (numba, :mod:`core.jit`).

:func:`core.sampling.sample_thinned` keeps one point per occupied cube of
a third of a voxel: the mean of the points sampled in it. numpy makes each
point's cell number in three passes over the chunk, the runs of equal cells
in two more, then repeats the runs' numbers over their points and sums the
coordinates with four ``np.bincount``: on Zurich's CityJSON at 0.5 m (2.7 M
cells kept from 122 M points in 475 chunks), most of its 4.7 s. Here one pass
makes the cells and their runs (:func:`cell_runs`), and one more sums the
points of each run into its cell (:func:`run_sums`): 4.7 -> 2.6 s (the
samples themselves, numpy's matrix products, and the sort of the runs' cells
remain). Blocks of points on both cores gained nothing measurable.

The numbers are numpy's: the cell is the floor of the same quotient, and
each cell's sums add its points in the order ``np.bincount`` adds them, one
after the other in the order of the points.
"""
from __future__ import annotations

import numpy as np

from .neighbours_kernel import compiled


def cell_runs(points: np.ndarray, cell: float, low: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The cell number of each run of points in one cell, and where each run
    starts: :func:`core.sampling._cell_means`'s ``key[starts]`` and ``starts``.

    Examples
    --------
    >>> points = np.array([[0.1, 0.1, 0.1], [0.2, 0.1, 0.1], [1.5, 0.1, 0.1], [0.3, 0.3, 0.3]])
    >>> keys, starts = cell_runs(points, 1.0, np.zeros(3, np.int64))
    >>> keys.tolist(), starts.tolist()
    ([0, 1, 0], [0, 2, 3])
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    keys = np.empty(len(points), np.int64)
    starts = np.empty(len(points), np.int64)
    n = _cell_runs(points, float(cell), np.ascontiguousarray(low, dtype=np.int64), keys, starts)
    return keys[:n].copy(), starts[:n].copy()


def run_sums(points: np.ndarray, starts: np.ndarray, run_cell: np.ndarray,
             n_cells: int) -> tuple[np.ndarray, np.ndarray]:
    """The sums of the coordinates (C, 3) and the numbers of points (C,) of
    each of ``n_cells`` cells, the points of run ``r`` (from ``starts[r]`` to
    the next run) in cell ``run_cell[r]``.

    Examples
    --------
    >>> points = np.array([[0.1, 0.1, 0.1], [0.2, 0.1, 0.1], [1.5, 0.1, 0.1], [0.3, 0.3, 0.3]])
    >>> sums, counts = run_sums(points, np.array([0, 2, 3]), np.array([0, 1, 0]), 2)
    >>> sums[:, 0].round(12).tolist(), counts.tolist()
    ([0.6, 1.5], [3.0, 1.0])
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    sums = np.zeros((n_cells, 3))
    counts = np.zeros(n_cells)
    _run_sums(points, np.ascontiguousarray(starts, dtype=np.int64), np.ascontiguousarray(run_cell, dtype=np.int64),
              sums, counts)
    return sums, counts


def warm_up() -> int:
    """Compile for the types :mod:`core.sampling` passes."""
    points = np.array([[0.1, 0.1, 0.1], [0.2, 0.1, 0.1], [1.5, 0.1, 0.1], [0.3, 0.3, 0.3]])
    keys, starts = cell_runs(points, 1.0, np.zeros(3, np.int64))
    assert keys.tolist() == [0, 1, 0] and starts.tolist() == [0, 2, 3], (keys, starts)
    sums, counts = run_sums(points, starts, np.array([0, 1, 0], np.intp), 2)
    assert counts.tolist() == [3.0, 1.0] and abs(sums[1, 0] - 1.5) < 1e-12, (sums, counts)
    return 1


@compiled
def _cell_runs(points, cell, low, keys, starts):
    """Cells of the runs of ``points`` into ``keys`` and their first points
    into ``starts``; returns the number of runs."""
    n = 0
    last = -1
    for p in range(len(points)):
        i = np.int64(np.floor(points[p, 0] / cell)) - low[0]
        j = np.int64(np.floor(points[p, 1] / cell)) - low[1]
        k = np.int64(np.floor(points[p, 2] / cell)) - low[2]
        key = i | (j << 21) | (k << 42)
        if p == 0 or key != last:
            keys[n] = key
            starts[n] = p
            n += 1
            last = key
    return n


@compiled
def _run_sums(points, starts, run_cell, sums, counts):
    """Each run's points added to its cell's sums, in their order; its size to the count."""
    n_runs = len(starts)
    for r in range(n_runs):
        c = run_cell[r]
        stop = starts[r + 1] if r + 1 < n_runs else len(points)
        for p in range(starts[r], stop):
            sums[c, 0] += points[p, 0]
            sums[c, 1] += points[p, 1]
            sums[c, 2] += points[p, 2]
        counts[c] += stop - starts[r]
