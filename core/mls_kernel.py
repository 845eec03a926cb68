"""Compiled weighted moments of the MLS planes (numba, :mod:`core.jit`).

:func:`core.mls.weighted_moments` gathers each row's 12 data points into a
(Q, 12, 3) table and sums their weighted coordinates and products with
whole-array passes over it, one point at a time: for the 900 k planes of
the 1 km synthetic city's buildings, 0.35 s on one core, as much as the
einsum and BLAS products it replaced. Here one pass per row reads its
points once and makes the same sums, each multiplication and addition in
the same order, so the moments are numpy's to the last bit.
"""
from __future__ import annotations

import numpy as np

from .neighbours_kernel import compiled


def weighted_moments(data: np.ndarray, idx: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`core.mls.weighted_moments`: the weighted centroid (Q, 3) and
    weighted scatter (Q, 3, 3) of each row's data points, on this thread
    (the planes' blocks run on the pool's threads).

    Examples
    --------
    >>> data = np.array([[0.0, 0, 0], [2, 0, 0], [0, 2, 0], [2, 2, 0]])
    >>> centre, scatter = weighted_moments(data, np.array([[0, 1, 2, 3]]), np.full((1, 4), 0.25))
    >>> centre.tolist(), scatter[0].tolist()
    ([[1.0, 1.0, 0.0]], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]])
    """
    data = np.ascontiguousarray(data, dtype=np.float64)
    w = np.ascontiguousarray(w, dtype=np.float64)
    centre = np.empty((len(idx), 3))
    scatter = np.empty((len(idx), 3, 3))
    _moments(data, np.ascontiguousarray(idx), w, centre, scatter)
    return centre, scatter


def warm_up() -> int:
    """Compile for the types :mod:`core.mls` passes (intp neighbours)."""
    data = np.array([[0.0, 0, 0], [2, 0, 0], [0, 2, 0], [2, 2, 0]])
    centre, scatter = weighted_moments(data, np.array([[0, 1, 2, 3]], dtype=np.intp), np.full((1, 4), 0.25))
    assert centre.tolist() == [[1.0, 1.0, 0.0]] and scatter[0, 1, 1] == 1.0, (centre, scatter)
    return 1


@compiled
def _moments(data, idx, w, centre, scatter):
    """:func:`weighted_moments` of every row into ``centre`` and ``scatter``."""
    k = idx.shape[1]
    for q in range(len(idx)):
        cx, cy, cz = 0.0, 0.0, 0.0
        for j in range(k):
            i, wj = idx[q, j], w[q, j]
            cx += wj * data[i, 0]
            cy += wj * data[i, 1]
            cz += wj * data[i, 2]
        s00 = s10 = s11 = s20 = s21 = s22 = 0.0
        for j in range(k):
            i, wj = idx[q, j], w[q, j]
            dx, dy, dz = data[i, 0] - cx, data[i, 1] - cy, data[i, 2] - cz
            wx, wy, wz = wj * dx, wj * dy, wj * dz
            s00 += wx * dx
            s10 += wy * dx
            s11 += wy * dy
            s20 += wz * dx
            s21 += wz * dy
            s22 += wz * dz
        centre[q, 0], centre[q, 1], centre[q, 2] = cx, cy, cz
        scatter[q, 0, 0], scatter[q, 0, 1], scatter[q, 0, 2] = s00, s10, s20
        scatter[q, 1, 0], scatter[q, 1, 1], scatter[q, 1, 2] = s10, s11, s21
        scatter[q, 2, 0], scatter[q, 2, 1], scatter[q, 2, 2] = s20, s21, s22
