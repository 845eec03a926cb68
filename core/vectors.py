"""3-vectors held as one array per coordinate, with numpy's own arithmetic.

Operations on (P, 3) arrays (``np.cross``, ``einsum`` dot products, norms
along the last axis) run numpy's loops three elements long; with a list of
three contiguous (P,) arrays per vector every operation runs on P numbers
at once, two to three times faster on the mesh-sized tables of the
quality control, the crossing test and the measures. The functions here
do the very operations of their numpy counterparts, in the same order, so
code moved to them gives the same numbers to the last bit:

* :func:`cross` is ``np.cross``;
* :func:`dot` is ``np.einsum("ij,ij->i", u, v)``, which in numpy 1.24 adds
  the x and z products first, then the y one;
* :func:`length` is ``np.linalg.norm(v, axis=1)``.

Rows of 2-D tables (nodes, quads, triangles, points) are gathered with
``table.take(index, axis=0)`` and selected with ``table.compress(mask,
axis=0)`` throughout the core: the rows of ``table[index]`` and
``table[mask]``, which numpy 1.24 copies through its generic indexing loop,
3 to 7 times slower on (N, 3) and (M, 4) tables (``compress`` is also 2.5
times faster on a 1-D array). A 1-D table keeps plain indexing: as fast,
and ``take`` is slower with a large int32 index.
"""
from __future__ import annotations

import numpy as np

Vector = list  # [x, y, z]: three arrays of the same shape


def coordinates(nodes: np.ndarray, index: np.ndarray) -> Vector:
    """The rows ``index`` of an (N, 3) table as three contiguous arrays.

    Examples
    --------
    >>> coordinates(np.arange(9.0).reshape(3, 3), np.array([2, 0]))
    [array([6., 0.]), array([7., 1.]), array([8., 2.])]
    """
    return [nodes[:, c][index] for c in range(3)]


def cross(u: Vector, v: Vector) -> Vector:
    """Cross product, as ``np.cross``.

    Examples
    --------
    >>> [float(c) for c in cross([1.0, 0.0, 0.0], [0.0, 1.0, 0.0])]
    [0.0, 0.0, 1.0]
    """
    return [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]


def dot(u: Vector, v: Vector) -> np.ndarray:
    """Dot product, as ``np.einsum("ij,ij->i", u, v)`` (x and z first).

    Examples
    --------
    >>> u, v = np.random.default_rng(0).normal(size=(2, 1000, 3))
    >>> bool(np.array_equal(dot(list(u.T), list(v.T)), np.einsum("ij,ij->i", u, v)))
    True
    """
    return (u[0] * v[0] + u[2] * v[2]) + u[1] * v[1]


def length(v: Vector) -> np.ndarray:
    """Euclidean length, as ``np.linalg.norm(v, axis=1)``.

    Examples
    --------
    >>> v = np.random.default_rng(0).normal(size=(1000, 3))
    >>> bool(np.array_equal(length(list(v.T)), np.linalg.norm(v, axis=1)))
    True
    """
    return np.sqrt((v[0] * v[0] + v[1] * v[1]) + v[2] * v[2])


def minus(u: Vector, v: Vector) -> Vector:
    """Difference ``u - v``."""
    return [u[c] - v[c] for c in range(3)]


def all_finite(table: np.ndarray) -> bool:
    """Whether every number of ``table`` is finite, from the sum of them all
    (one pass, no mask): a NaN or an infinity makes the sum non-finite. A
    sum that overflows (numbers near 1e308) is checked number by number.

    Examples
    --------
    >>> all_finite(np.array([[0.0, 1, 2]])), all_finite(np.array([[0.0, np.inf, -np.inf]]))
    (True, False)
    >>> all_finite(np.array([1e308, 1e308]))
    True
    """
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow or inf - inf is an answer here
        total = table.sum()
    return bool(np.isfinite(total)) or bool(np.isfinite(table).all())


def finite_rows(table: np.ndarray) -> np.ndarray:
    """Whether every coordinate of each row of an (N, 3) table is finite, as
    ``np.isfinite(table).all(axis=1)``, one column at a time (numpy's
    ``all`` along rows of three is slow on millions of points).

    Examples
    --------
    >>> finite_rows(np.array([[0.0, 1, 2], [0, np.nan, 2]])).tolist()
    [True, False]
    """
    return np.isfinite(table[:, 0]) & np.isfinite(table[:, 1]) & np.isfinite(table[:, 2])
