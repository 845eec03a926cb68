"""Compiled choice of the data points a node tries (numba, :mod:`core.jit`).

Step 1 of the projection (:mod:`core.project`): among a node's 24 nearest
data points, the few closest to the line through the node along its normal,
ties broken by the points' coordinates. numpy does it with a (Q, 24) table
of distances, a partial sort, a sort of the first few columns and a full
lexsort of the rows with ties: 1.3 s for the 5 M nodes of the 1 km synthetic
city. Here each row is one pass that keeps its best few in order, with the
arithmetic of :func:`core.project._distance_to_line` operation for operation
and the order of :func:`core.project._ranked` (distance, then x, y, z, then
the column), so the chosen points are the same; the tests compare both.
"""
from __future__ import annotations

import numpy as np

from .neighbours_kernel import before, compiled
from .parallel import map_blocks, thread_blocks


def closest_to_lines(data: np.ndarray, near: np.ndarray, p: np.ndarray, normal: np.ndarray,
                     tries: int) -> np.ndarray:
    """The ``tries`` data points of each row of ``near`` closest to the line
    through ``p`` along ``normal``, closest first: the indices
    ``np.take_along_axis(near, _ranked(_distance_to_line(...)), axis=1)``
    of :mod:`core.project`.

    Parameters
    ----------
    data : ndarray (P, 3)
    near : ndarray of int (Q, K)
        Data point indices, ``len(data)`` for a missing one.
    p, normal : ndarray (Q, 3)
    tries : int

    Returns
    -------
    ndarray of intp (Q, min(tries, K))

    Examples
    --------
    >>> data = np.array([[3.0, 4.0, 7.0], [0.0, 0.0, -2.0], [0.0, 1.0, 5.0]])
    >>> closest_to_lines(data, np.array([[0, 1, 2, 3]]), np.zeros((1, 3)), np.array([[0.0, 0, 1]]), 2)
    array([[1, 2]])
    """
    data = np.ascontiguousarray(data, dtype=np.float64)
    near = np.ascontiguousarray(near, dtype=np.intp)
    p = np.ascontiguousarray(p, dtype=np.float64)
    normal = np.ascontiguousarray(normal, dtype=np.float64)
    out = np.empty((len(near), min(tries, near.shape[1])), dtype=np.intp)

    def fill(rows: slice) -> None:
        _closest(data, near, p, normal, rows.start, rows.stop, out)

    map_blocks(fill, thread_blocks(len(near)))
    return out


def warm_up() -> int:
    """Compile for the types :func:`core.project._candidates` passes."""
    data = np.array([[3.0, 4.0, 7.0], [0.0, 0.0, -2.0], [0.0, 1.0, 5.0]])
    out = closest_to_lines(data, np.array([[0, 1, 2, 3]]), np.zeros((1, 3)), np.array([[0.0, 0, 1]]), 2)
    assert out.tolist() == [[1, 2]], out
    return 1


@compiled
def _off_line(x, y, z, px, py, pz, nx, ny, nz):
    """Distance of (x, y, z) to the line through p along n, as
    :func:`core.project._distance_to_line` computes it (``vectors.dot`` sums
    x and z first, ``vectors.length`` x and y)."""
    ox, oy, oz = x - px, y - py, z - pz
    along = (ox * nx + oz * nz) + oy * ny
    ex, ey, ez = ox - along * nx, oy - along * ny, oz - along * nz
    return np.sqrt((ex * ex + ey * ey) + ez * ez)


@compiled
def _closest(data, near, p, normal, start, stop, out):
    """Rows ``start:stop`` of :func:`closest_to_lines`."""
    k, tries, n = near.shape[1], out.shape[1], len(data)
    keep = np.empty(tries, np.intp)
    key = np.empty((tries, 4))
    column = np.empty(tries, np.intp)
    for q in range(start, stop):
        px, py, pz = p[q, 0], p[q, 1], p[q, 2]
        nx, ny, nz = normal[q, 0], normal[q, 1], normal[q, 2]
        kept = 0
        for j in range(k):
            i = near[q, j]
            # lexsort's key of a missing neighbour: infinitely far, at the last point.
            c = i if i < n else n - 1
            x, y, z = data[c, 0], data[c, 1], data[c, 2]
            d = _off_line(x, y, z, px, py, pz, nx, ny, nz) if i < n else np.inf
            # Insert in order; the column breaks ties last, as a stable sort.
            slot = kept
            while slot > 0 and before(d, x, y, z, j, key[slot - 1, 0], key[slot - 1, 1],
                                      key[slot - 1, 2], key[slot - 1, 3], column[slot - 1]):
                slot -= 1
            if slot >= tries:
                continue
            last = kept if kept < tries else tries - 1
            for s in range(last, slot, -1):
                keep[s], column[s] = keep[s - 1], column[s - 1]
                key[s, 0], key[s, 1], key[s, 2], key[s, 3] = key[s - 1, 0], key[s - 1, 1], key[s - 1, 2], key[s - 1, 3]
            keep[slot], column[slot] = i, j
            key[slot, 0], key[slot, 1], key[slot, 2], key[slot, 3] = d, x, y, z
            if kept < tries:
                kept += 1
        for s in range(tries):
            out[q, s] = keep[s]
