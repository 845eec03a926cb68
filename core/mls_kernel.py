"""Compiled weighted moments and least axes of the MLS planes (numba, :mod:`core.jit`).

:func:`core.mls.weighted_moments` gathers each row's 12 data points into a
(Q, 12, 3) table and sums their weighted coordinates and products with
whole-array passes over it, one point at a time: for the 900 k planes of
the 1 km synthetic city's buildings, 0.35 s on one core, as much as the
einsum and BLAS products it replaced. Here one pass per row reads its
points once and makes the same sums, each multiplication and addition in
the same order, so the moments are numpy's to the last bit.

:func:`core.mls.least_axis` is some sixty whole-array operations on the
rows of a block: 0.34 s on one core for those 900 k planes. Here two passes
per row make the same arithmetic (:func:`least_axis`), and numpy makes, in
between, what must stay numpy's: the power, the arc cosine and the cosines,
which numpy takes from its own vectorised library (SVML on AVX-512), not
from the C library a compiled loop calls, and which then differ in the last
bit.
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


def least_axis(cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`core.mls.least_axis`: the unit eigenvector of the smallest
    eigenvalue and the eigenvalues, ascending, of the symmetric 3 x 3
    matrices ``cov`` (lower triangles read), on this thread.

    Examples
    --------
    A matrix whose least axis is off the coordinate axes, (1, -1, 0) / sqrt(2):

    >>> normal, values = least_axis(np.array([[[2.0, 1, 0], [1, 2, 0], [0, 0, 5]]]))
    >>> (np.abs(normal) * np.sqrt(2)).round(12).tolist(), values.round(12).tolist()
    ([[1.0, 1.0, 0.0]], [[1.0, 3.0, 5.0]])
    """
    cov = np.ascontiguousarray(cov, dtype=np.float64)
    mean, spread, twice_det = np.empty(len(cov)), np.empty(len(cov)), np.empty(len(cov))
    _characteristic(cov, mean, spread, twice_det)
    # numpy's, as core.mls.least_axis makes them (see the module doc).
    scale = np.where(spread > 0, spread, 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):  # as core.mls.least_axis: 0 / 0 where the cube underflows
        half_det = twice_det / (2 * scale**3)
    angle = np.arccos(np.clip(half_det, -1.0, 1.0)) / 3
    high_cos, low_cos = np.cos(angle), np.cos(angle + 2 * np.pi / 3)
    normal, values = np.empty((len(cov), 3)), np.empty((len(cov), 3))
    _axes(cov, mean, spread, high_cos, low_cos, normal, values)
    return normal, values


def warm_up() -> int:
    """Compile for the types :mod:`core.mls` passes (intp neighbours)."""
    data = np.array([[0.0, 0, 0], [2, 0, 0], [0, 2, 0], [2, 2, 0]])
    centre, scatter = weighted_moments(data, np.array([[0, 1, 2, 3]], dtype=np.intp), np.full((1, 4), 0.25))
    assert centre.tolist() == [[1.0, 1.0, 0.0]] and scatter[0, 1, 1] == 1.0, (centre, scatter)
    normal, values = least_axis(scatter)
    assert np.abs(normal).tolist() == [[0.0, 0.0, 1.0]] and abs(values[0, 2] - 1.0) < 1e-6, (normal, values)
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


@compiled
def _characteristic(cov, mean, spread, twice_det):
    """Per matrix: the mean of the diagonal, the spread of the eigenvalues
    about it, and the determinant of ``cov - mean * I`` before its scaling,
    with :func:`core.mls.least_axis`'s operations in its order."""
    for q in range(len(cov)):
        a00, a11, a22 = cov[q, 0, 0], cov[q, 1, 1], cov[q, 2, 2]
        a01, a02, a12 = cov[q, 1, 0], cov[q, 2, 0], cov[q, 2, 1]
        m = (a00 + a11 + a22) / 3
        b00, b11, b22 = a00 - m, a11 - m, a22 - m
        mean[q] = m
        spread[q] = np.sqrt((b00 * b00 + b11 * b11 + b22 * b22 + 2 * (a01 * a01 + a02 * a02 + a12 * a12)) / 6)
        twice_det[q] = (b00 * (b11 * b22 - a12 * a12) - a01 * (a01 * b22 - a12 * a02)
                        + a02 * (a01 * a12 - b11 * a02))


@compiled
def _axes(cov, mean, spread, high_cos, low_cos, normal, values):
    """Per matrix: the eigenvalues from the cosines, and the least axis
    refined by its Rayleigh quotient (:func:`core.mls.least_axis`)."""
    for q in range(len(cov)):
        a00, a11, a22 = cov[q, 0, 0], cov[q, 1, 1], cov[q, 2, 2]
        a01, a02, a12 = cov[q, 1, 0], cov[q, 2, 0], cov[q, 2, 1]
        high = mean[q] + 2 * spread[q] * high_cos[q]
        low = mean[q] + 2 * spread[q] * low_cos[q]
        values[q, 0], values[q, 1], values[q, 2] = low, 3 * mean[q] - high - low, high
        vx, vy, vz = _null_vector(a00, a11, a22, a01, a02, a12, low)
        cx = a00 * vx + a01 * vy + a02 * vz
        cy = a01 * vx + a11 * vy + a12 * vz
        cz = a02 * vx + a12 * vy + a22 * vz
        refined = vx * cx + vy * cy + vz * cz
        normal[q, 0], normal[q, 1], normal[q, 2] = _null_vector(a00, a11, a22, a01, a02, a12, refined)


@compiled
def _null_vector(a00, a11, a22, a01, a02, a12, value):
    """The longest cross product of two rows of ``cov - value * I``, as a
    unit vector ((0, 0, 1) where all are zero): ``null_vector`` of
    :func:`core.mls.least_axis`, the first longest of the three pairs."""
    r00, r01, r02 = a00 - value, a01, a02
    r10, r11, r12 = a01, a11 - value, a12
    r20, r21, r22 = a02, a12, a22 - value
    bx, by, bz = r01 * r12 - r02 * r11, r02 * r10 - r00 * r12, r00 * r11 - r01 * r10
    best = bx * bx + by * by + bz * bz
    cx, cy, cz = r01 * r22 - r02 * r21, r02 * r20 - r00 * r22, r00 * r21 - r01 * r20
    length2 = cx * cx + cy * cy + cz * cz
    if length2 > best:
        bx, by, bz, best = cx, cy, cz, length2
    cx, cy, cz = r11 * r22 - r12 * r21, r12 * r20 - r10 * r22, r10 * r21 - r11 * r20
    length2 = cx * cx + cy * cy + cz * cz
    if length2 > best:
        bx, by, bz, best = cx, cy, cz, length2
    size = np.sqrt(best)
    if size > 0:
        return bx / size, by / size, bz / size
    return 0.0, 0.0, 1.0
