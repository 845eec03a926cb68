"""Moving-least-squares planes of the data (paper §4.2, step 2 of :mod:`core.project`).

The plane at a data point is fitted to its ``PLANE_POINTS`` nearest data
points with Gaussian weights: their weighted centroid, and the principal
axis of least weighted variance as its normal (a closed-form 3 x 3
eigen-solver, :func:`least_axis`). The projection fits one at each data
point a node tries (:class:`PlaneCache`), about 1.9 M planes on the 1 km
synthetic city.

The weighted moments (:func:`weighted_moments`) are sums over each
point's neighbours in their order, one multiplication and one addition at
a time, so that the compiled pass (:mod:`core.mls_kernel`) gives the same
numbers to the last bit. They replaced ``np.einsum`` and a stacked
``np.matmul``, which calls BLAS, whose order of operations is its own. On
the 1 km synthetic city the centroids are einsum's to the last bit, the
scatter matrices BLAS's to 4e-16 of their largest entry, and the normals of
the flat planes agree to 2e-6 degrees. The projection makes the same moves,
and the final nodes differ by at most 2e-13 m. For the 900 k building
planes on one core, the compiled pass takes 0.07 s; numpy's gathers and
products took 0.37 s. The least axes (:func:`least_axis`) are compiled
too, with numpy's power, arc cosine and cosines: 0.34 -> 0.04 s for the
same 900 k planes on one core.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from . import jit
from .neighbours import PointSearch, nearest
from .parallel import map_ahead, on_pool, row_blocks, take_rows
from .vectors import cross

#: Data points per plane.
PLANE_POINTS = 12
#: Planes fitted per block of rows (temporaries of a few MB).
FIT_ROWS = 16384
#: Scatters whose trace is below this are scaled up before their least axis
#: (:func:`of_normal_size`).
TINY_TRACE = 2.0 ** -200


def mls_planes(data: np.ndarray, tree: PointSearch, at: np.ndarray, sigma: float,
               k: int = PLANE_POINTS, fitted: Callable[[float], None] | None = None,
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weighted least-squares planes of the data around points ``at``;
    ``fitted(share)`` is told the share of them fitted so far, block by block
    (from this thread).

    Returns
    -------
    centre : ndarray (Q, 3)
        Weighted centroid, a point of the plane.
    normal : ndarray (Q, 3)
        Unit normal: the principal axis of least weighted variance
        (:func:`least_axis`).
    flat : ndarray of bool (Q,)
        The neighbourhood spans a plane (not a line or a point).
    """
    blocks = row_blocks(len(at), FIT_ROWS)
    # One thread per query where the blocks run on the pool's threads.
    workers = 1 if on_pool(blocks) else None

    def fit(rows: slice) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        # The neighbours of a block of rows only: tables of all of them took
        # hundreds of MB on a city.
        dist, idx = nearest(tree, data, at[rows], k, workers=workers)
        w = np.exp(-(dist / sigma) ** 2)
        w /= np.maximum(w.sum(axis=1, keepdims=True), 1e-300)
        centre, cov = weighted_moments(data, idx, w)
        normal, values = least_axis(of_normal_size(cov))
        return centre, normal, values[:, 1] > 1e-3 * np.maximum(values[:, 2], 1e-300)

    # Each plane is fitted from its own rows: blocks of rows run on all cores
    # (the KD-tree searches release the GIL), taken here in order as they end.
    parts = []
    for part in map_ahead(fit, blocks):
        parts.append(part)
        if fitted is not None:
            fitted(len(parts) / len(blocks))
    parts = parts or [fit(slice(0, 0))]
    return tuple(np.concatenate([part[i] for part in parts]) for i in range(3))


def of_normal_size(scatter: np.ndarray) -> np.ndarray:
    """The scatters (Q, 3, 3), in place, those of a trace below
    :data:`TINY_TRACE` (and above zero) multiplied by a power of two that
    brings the trace into [0.5, 1).

    A data point whose neighbours all lie a dozen sigmas away or more weighs
    them by 1e-63 or less beside itself: the scatter is that small, and the
    squares and cubes in :func:`least_axis` underflow. Past 16 sigmas its
    spread's cube is zero (NaN axes, no plane); past 19 sigmas the squares
    are, and the three eigenvalues come out equal: a "flat" plane with the
    normal (0, 0, 1), whatever the neighbours' layout. The plane does not
    depend on the scatter's scale, and a power of two changes no bit of the
    entries, so the scaled scatter gives the plane of the neighbours as they
    lie and weigh, as ``np.linalg.eigh`` (which scales such matrices too)
    finds it: their plane where they lie on one, no plane on a line or where
    the nearest outweighs the others. Every other scatter is left as it is,
    to the last bit. A zero trace (no neighbour with any weight, or
    all of them on the point) stays zero: no plane.

    Examples
    --------
    >>> scatter = np.diag(np.ldexp([3.0, 1.0, 0.0], -700))[None]  # trace 2**-698
    >>> of_normal_size(scatter)[0].diagonal().tolist()
    [0.375, 0.125, 0.0]
    >>> of_normal_size(np.diag([4.0, 2.0, 0.0])[None])[0].diagonal().tolist()
    [4.0, 2.0, 0.0]
    """
    trace = scatter[:, 0, 0] + scatter[:, 1, 1] + scatter[:, 2, 2]
    tiny = np.flatnonzero((trace < TINY_TRACE) & (trace > 0))
    if len(tiny):
        _, exponent = np.frexp(trace[tiny])
        scatter[tiny] = np.ldexp(scatter[tiny], -exponent[:, None, None])
    return scatter


def weighted_moments(data: np.ndarray, idx: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted centroid and weighted scatter of each row's data points.

    Parameters
    ----------
    data : ndarray (P, 3)
    idx : ndarray of int (Q, K)
        The points of each row (valid indices).
    w : ndarray (Q, K)
        Their weights (summing to one in each row).

    Returns
    -------
    centre : ndarray (Q, 3)
        ``sum_k w_k x_k``, summed in the order of the points.
    scatter : ndarray (Q, 3, 3)
        ``sum_k (w_k d_k) d_k^T`` with ``d_k = x_k - centre``, the same way:
        the lower triangle, mirrored (what :func:`least_axis` reads).

    Examples
    --------
    >>> data = np.array([[0.0, 0, 0], [2, 0, 0], [0, 2, 0], [2, 2, 0]])
    >>> centre, scatter = weighted_moments(data, np.array([[0, 1, 2, 3]]), np.full((1, 4), 0.25))
    >>> centre.tolist(), np.diag(scatter[0]).tolist()
    ([[1.0, 1.0, 0.0]], [1.0, 1.0, 0.0])
    """
    # One compiled pass per row, the same numbers (core.mls_kernel).
    found = jit.run("mls_kernel", "weighted_moments", data, idx, w, size=len(idx))
    if found is not None:
        return found
    points = [data.take(idx[:, j], axis=0) for j in range(idx.shape[1])]
    centre = np.zeros((len(idx), 3))
    for j, x in enumerate(points):
        centre += w[:, j, None] * x
    scatter = np.zeros((len(idx), 3, 3))
    for j, x in enumerate(points):
        d = x - centre
        wd = w[:, j, None] * d
        for a in range(3):
            for b in range(a + 1):
                scatter[:, a, b] += wd[:, a] * d[:, b]
    for a, b in ((0, 1), (0, 2), (1, 2)):
        scatter[:, a, b] = scatter[:, b, a]
    return centre, scatter


def least_axis(cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit eigenvector of the smallest eigenvalue, and the eigenvalues in
    ascending order, of symmetric 3 x 3 matrices ``cov`` (Q, 3, 3).

    The eigenvalues come in closed form (the trigonometric solution of the
    characteristic cubic), the vector as the longest cross product of two
    rows of ``cov - value * I``, then again with the value refined as the
    Rayleigh quotient of that vector. Five times faster than
    ``np.linalg.eigh`` (one LAPACK call per matrix); the vectors agree with
    it to 1e-13 wherever the two smallest eigenvalues differ by more than
    1e-3 of the largest (the planes that count as flat), the eigenvalues to
    1e-9 of the largest (near a double root; 1e-15 elsewhere). Only the lower
    triangle is read. Where the smallest eigenvalue is double, any unit
    vector of its plane may come, as from ``eigh``; where every cross
    product is zero (a multiple of the identity), (0, 0, 1).

    Examples
    --------
    >>> cov = np.array([[[2.0, 0, 0], [0, 3, 0], [0, 0, 0.5]]])
    >>> normal, values = least_axis(cov)
    >>> np.abs(normal).round(12).tolist(), values.round(12).tolist()
    ([[0.0, 0.0, 1.0]], [[0.5, 2.0, 3.0]])
    """
    # Two compiled passes per matrix, the same numbers (core.mls_kernel).
    found = jit.run("mls_kernel", "least_axis", cov, size=len(cov))
    if found is not None:
        return found
    a00, a11, a22 = cov[:, 0, 0], cov[:, 1, 1], cov[:, 2, 2]
    a01, a02, a12 = cov[:, 1, 0], cov[:, 2, 0], cov[:, 2, 1]
    mean = (a00 + a11 + a22) / 3
    b00, b11, b22 = a00 - mean, a11 - mean, a22 - mean
    spread = np.sqrt((b00 * b00 + b11 * b11 + b22 * b22 + 2 * (a01 * a01 + a02 * a02 + a12 * a12)) / 6)
    scale = np.where(spread > 0, spread, 1.0)
    # A spread whose cube underflows to zero (weights that all underflowed:
    # a point whose neighbours all lie dozens of sigmas away) gives 0 / 0: NaN
    # axes and values, a plane that is not flat, with no warning.
    with np.errstate(invalid="ignore", divide="ignore"):
        half_det = (b00 * (b11 * b22 - a12 * a12) - a01 * (a01 * b22 - a12 * a02)
                    + a02 * (a01 * a12 - b11 * a02)) / (2 * scale**3)
    angle = np.arccos(np.clip(half_det, -1.0, 1.0)) / 3
    high = mean + 2 * spread * np.cos(angle)
    low = mean + 2 * spread * np.cos(angle + 2 * np.pi / 3)
    values = np.stack([low, 3 * mean - high - low, high], axis=1)

    def null_vector(value: np.ndarray) -> np.ndarray:
        rows = ([a00 - value, a01, a02], [a01, a11 - value, a12], [a02, a12, a22 - value])
        best, best_length2 = None, None
        for u, v in ((rows[0], rows[1]), (rows[0], rows[2]), (rows[1], rows[2])):
            c = cross(u, v)
            length2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2]
            if best is None:
                best, best_length2 = c, length2
            else:
                longer = length2 > best_length2
                best = [np.where(longer, c[i], best[i]) for i in range(3)]
                best_length2 = np.where(longer, length2, best_length2)
        size = np.sqrt(best_length2)
        found = size > 0
        size = np.where(found, size, 1.0)
        return np.stack([np.where(found, best[0] / size, 0.0), np.where(found, best[1] / size, 0.0),
                         np.where(found, best[2] / size, 1.0)], axis=1)

    normal = null_vector(low)
    # The eigenvalue from the closed form is off by round-off times the
    # largest one, which tilts the vector by ~1e-11 rad on flat data: the
    # Rayleigh quotient of that vector is exact to second order.
    v = [normal[:, 0], normal[:, 1], normal[:, 2]]
    cov_v = [a00 * v[0] + a01 * v[1] + a02 * v[2], a01 * v[0] + a11 * v[1] + a12 * v[2],
             a02 * v[0] + a12 * v[1] + a22 * v[2]]
    refined = v[0] * cov_v[0] + v[1] * cov_v[1] + v[2] * cov_v[2]
    return null_vector(refined), values


class PlaneCache:
    """The MLS planes (:func:`mls_planes`) at data points, each fitted once:
    neighbouring nodes often pick the same point, and a point one node tries
    first, another may try next (on the 1 km synthetic city, 6 % of the
    second and third tries).

    The planes are found through a table of one slot per data point, not by
    sorting the points asked for (``np.unique``, then a search among those
    fitted before): 0.28 s of the two projections' 2.2 s on the 1 km city
    went to that bookkeeping."""

    def __init__(self, data: np.ndarray, tree: PointSearch, sigma: float):
        self.data, self.tree, self.sigma = data, tree, sigma
        #: Row of each data point's plane in the tables below, -1 if not fitted yet.
        self.slot = np.full(len(data), -1, dtype=np.int32 if len(data) < 2**31 else np.int64)
        self.centre, self.normal = np.empty((0, 3)), np.empty((0, 3))
        self.flat = np.empty(0, dtype=bool)

    def __call__(self, points: np.ndarray, fitted: Callable[[float], None] | None = None,
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Centre, normal and flatness (as :func:`mls_planes`) of the planes at
        ``points`` (data indices); ``fitted`` as there, of the planes not fitted before."""
        # Gathers of rows scattered over tables of every data point: on all cores.
        row = take_rows(self.slot, points)
        unfitted = row < 0
        missing = points.compress(unfitted)
        if len(missing):
            # The points not fitted yet, once each and ascending (as np.unique).
            wanted = np.zeros(len(self.data), dtype=bool)
            wanted[missing] = True
            new = np.flatnonzero(wanted)
            centre, normal, flat = mls_planes(self.data, self.tree, self.data.take(new, axis=0), self.sigma,
                                              PLANE_POINTS, fitted)
            self.slot[new] = np.arange(len(self.flat), len(self.flat) + len(new))
            self.centre = np.concatenate([self.centre, centre])
            self.normal = np.concatenate([self.normal, normal])
            self.flat = np.concatenate([self.flat, flat])
            # Only the points just fitted have new rows: not a second gather of them all.
            row[unfitted] = self.slot.take(missing)
        return take_rows(self.centre, row), take_rows(self.normal, row), take_rows(self.flat, row)
