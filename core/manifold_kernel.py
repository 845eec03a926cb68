"""Compiled search of the critical cubes (numba, :mod:`core.jit`).

The well-composed repair (:func:`core.manifold.make_well_composed`) starts
from every 2 x 2 x 2 cube of the grid whose label pattern is critical. numpy
sums the eight corners' labels times 3^bit in int16 slabs (eight shifted
views, a multiply and an add each), looks the sums up and lists the
critical ones: 0.3 s per call on the 85 M voxels of the 1 km synthetic city,
called twice a run. Here the cubes' sums are made row by row along z, on
all cores (slabs of x), and the rows that hold a critical cube list theirs:
the same cubes, ascending. On the same city at 0.5 m (680 M voxels, the
labels just classified, 11.8 k critical cubes among them): 2.1-2.5 s
counted then listed over the cubes one by one, 0.37-0.59 s so.

After the elimination only the cubes around the voxels it removed can be
critical (:func:`critical_around`): for the 1 km city's 365 k voxels, numpy
lists their 2.9 M cubes, sorts them and sums their corners in 0.3 s, more
than the scan of the whole grid; one pass over the voxels takes a few
hundredths of a second.
"""
from __future__ import annotations

import numpy as np

from .neighbours_kernel import compiled
from .parallel import map_blocks, thread_blocks

#: Cubes looked at per block of work on a core.
_SLAB_CUBES = 1 << 22


def critical_cubes(labels: np.ndarray, critical_by_sum: np.ndarray) -> np.ndarray:
    """Flat index (of the lowest corner) of every cube whose corners' labels,
    times 3^bit (bit ``4 di + 2 dj + dk`` for corner (di, dj, dk), as
    :data:`core.manifold.CORNERS`) and summed, are ``critical_by_sum``;
    ascending.

    Examples
    --------
    Two building voxels (2) meeting along an edge, in air (3):

    >>> labels = np.full((2, 2, 2), 3, np.uint8); labels[0, 0, :] = labels[1, 1, :] = 2
    >>> from core.manifold import _CRITICAL_BY_LABEL_SUM
    >>> critical_cubes(labels, _CRITICAL_BY_LABEL_SUM).tolist()
    [0]
    """
    labels = np.ascontiguousarray(labels)
    nx, ny, nz = labels.shape
    if nx < 2 or ny < 2 or nz < 2:
        return np.zeros(0, dtype=np.int64)
    critical_by_sum = np.ascontiguousarray(critical_by_sum, dtype=np.bool_)
    # Slabs of a few million cubes, many per thread (the one done first takes the
    # next), each listing its own cubes in one pass (they are few).
    slabs = thread_blocks(nx - 1, max(1, _SLAB_CUBES // max((ny - 1) * (nz - 1), 1)))
    return np.concatenate(map_blocks(lambda rows: _critical(labels, critical_by_sum, rows.start, rows.stop), slabs))


def critical_around(labels: np.ndarray, cells: np.ndarray, critical_by_sum: np.ndarray) -> np.ndarray:
    """Flat index (of the lowest corner) of every cube holding one of the
    voxels ``cells`` (flat indices) whose corners' labels sum as in
    :func:`critical_cubes` to ``critical_by_sum``; ascending, each once.

    Examples
    --------
    >>> labels = np.full((3, 2, 2), 3, np.uint8); labels[0, 0, :] = labels[1, 1, :] = 2
    >>> from core.manifold import _CRITICAL_BY_LABEL_SUM
    >>> critical_around(labels, np.array([11]), _CRITICAL_BY_LABEL_SUM).tolist()
    []
    >>> critical_around(labels, np.array([0, 6]), _CRITICAL_BY_LABEL_SUM).tolist()
    [0]
    """
    labels = np.ascontiguousarray(labels)
    if min(labels.shape) < 2 or len(cells) == 0:
        return np.zeros(0, dtype=np.int64)
    found = _critical_around(labels, np.ascontiguousarray(cells, dtype=np.int64),
                             np.ascontiguousarray(critical_by_sum, dtype=np.bool_))
    return np.unique(found)


def warm_up() -> int:
    """Compile for the labels the pipeline passes (uint8)."""
    from .manifold import _CRITICAL_BY_LABEL_SUM

    labels = np.full((2, 2, 2), 3, np.uint8)
    labels[0, 0, :] = labels[1, 1, :] = 2
    found = critical_cubes(labels, _CRITICAL_BY_LABEL_SUM)
    assert found.tolist() == [0], found
    found = critical_around(labels, np.array([0, 7]), _CRITICAL_BY_LABEL_SUM)
    assert found.tolist() == [0], found
    return 1


@compiled
def _critical(labels, critical_by_sum, start, stop):
    """The critical cubes whose lowest corner's x is in ``start:stop``, in order."""
    nx, ny, nz = labels.shape
    out = np.empty(1024, np.int64)
    n = 0
    # A cube's sum is that of its lower square (the four columns' labels at
    # its height, weighted 1, 9, 81, 729) plus three times its upper one, the
    # next cube's lower square: each square is summed once, a row of them at
    # a time. Critical cubes are rare: a row's are counted (a loop numba
    # vectorises), and listed only where there are any.
    square = np.empty(nz, np.int64)
    for i in range(start, stop):
        for j in range(ny - 1):
            for k in range(nz):
                square[k] = (np.int64(labels[i, j, k]) + 9 * np.int64(labels[i, j + 1, k])
                             + 81 * np.int64(labels[i + 1, j, k]) + 729 * np.int64(labels[i + 1, j + 1, k]))
            count = 0
            for k in range(nz - 1):
                count += critical_by_sum[square[k] + 3 * square[k + 1]]
            if count == 0:
                continue
            for k in range(nz - 1):
                if critical_by_sum[square[k] + 3 * square[k + 1]]:
                    if n == len(out):
                        grown = np.empty(2 * len(out), np.int64)
                        grown[:n] = out
                        out = grown
                    out[n] = (i * ny + j) * nz + k
                    n += 1
    return out[:n].copy()


@compiled
def _critical_around(labels, cells, critical_by_sum):
    """The critical cubes holding one of ``cells``, with repeats, in no order."""
    nx, ny, nz = labels.shape
    out = np.empty(8 * len(cells), np.int64)
    n = 0
    for c in cells:
        x, y, z = c // (ny * nz), (c // nz) % ny, c % nz
        for i in range(max(x - 1, 0), min(x, nx - 2) + 1):
            for j in range(max(y - 1, 0), min(y, ny - 2) + 1):
                for k in range(max(z - 1, 0), min(z, nz - 2) + 1):
                    total = (np.int64(labels[i, j, k]) + 3 * np.int64(labels[i, j, k + 1])
                             + 9 * np.int64(labels[i, j + 1, k]) + 27 * np.int64(labels[i, j + 1, k + 1])
                             + 81 * np.int64(labels[i + 1, j, k]) + 243 * np.int64(labels[i + 1, j, k + 1])
                             + 729 * np.int64(labels[i + 1, j + 1, k])
                             + 2187 * np.int64(labels[i + 1, j + 1, k + 1]))
                    if critical_by_sum[total]:
                        out[n] = (i * ny + j) * nz + k
                        n += 1
    return out[:n]
