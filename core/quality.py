"""Shape quality of triangles and quads, and quality-controlled node moves (§4).

The paper's criterion [Rassineux 2000] is the ratio of the inscribed radius
to the longest edge of a triangle, normalised here so that an equilateral
triangle scores 1 and a degenerate one 0::

    q = 2 * sqrt(3) * inradius / longest_edge = 4 * sqrt(3) * area / (perimeter * longest_edge)

A quad is judged through its split into two triangles: of the two
diagonals, the one giving the better worse triangle. A twisted quad (the two
triangles of a split facing opposite ways) only accepts the other split, and
a quad twisted both ways scores 0. A voxel face splits into two right
isosceles triangles: q = 0.717.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from . import jit
from .errors import Cancelled
from .parallel import map_blocks, row_blocks
from .topology import changed_rows, touching
from .vectors import coordinates, cross, dot, length

#: Quality of a voxel face (a square split along a diagonal).
SQUARE_QUALITY = float(4 * np.sqrt(3) * 0.5 / ((2 + np.sqrt(2)) * np.sqrt(2)))


def triangle_quality(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Normalised inradius / longest edge of triangles ``(a, b, c)``.

    Examples
    --------
    >>> eq = np.array([[0, 0, 0], [1, 0, 0], [0.5, np.sqrt(3) / 2, 0]])
    >>> float(np.round(triangle_quality(eq[:1], eq[1:2], eq[2:]), 6)[0])
    1.0
    """
    ab = np.linalg.norm(b - a, axis=-1)
    bc = np.linalg.norm(c - b, axis=-1)
    ca = np.linalg.norm(a - c, axis=-1)
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=-1)
    longest = np.maximum(np.maximum(ab, bc), ca)
    denominator = (ab + bc + ca) * longest
    return np.divide(4 * np.sqrt(3) * area, denominator, out=np.zeros_like(area),
                     where=denominator > 0)


def quad_normals(nodes: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Area-weighted normal of each quad (cross product of its diagonals, halved).

    One array per coordinate (:mod:`core.vectors`), the arithmetic of
    ``0.5 * np.cross(p2 - p0, p3 - p1)``.

    Examples
    --------
    A 2 x 1 rectangle in the plane z = 0 faces up with its area:

    >>> quad_normals(np.array([[0.0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0]]), np.array([[0, 1, 2, 3]]))[:, 2]
    array([2.])
    """
    x = coordinates(nodes, quads.T)  # (4, M) each
    return 0.5 * np.stack(cross([x[c][2] - x[c][0] for c in range(3)], [x[c][3] - x[c][1] for c in range(3)]),
                          axis=1)


def best_split(nodes: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split every quad along the diagonal that maximises the worse triangle's quality.

    Returns
    -------
    triangles : ndarray of int, shape (2M, 3)
        Triangles ``2m`` and ``2m + 1`` come from quad ``m``, same orientation.
    quality : ndarray of shape (M,)
        Quality of each quad under its chosen split (0 when twisted both ways).

    Examples
    --------
    A kite: the split along its long diagonal makes two slivers; the other is chosen.

    >>> nodes = np.array([[0, 0, 0], [1, -0.2, 0], [2, 0, 0], [1, 0.2, 0]], float)
    >>> tri, q = best_split(nodes, np.array([[0, 1, 2, 3]]))
    >>> tri.tolist()
    [[1, 2, 3], [1, 3, 0]]
    """
    use_second, quality, _ = _split_quality(nodes, quads, normals=False)
    return split_along(quads, use_second), quality


def best_diagonal(nodes: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Whether each quad's best split (:func:`best_split`) is along its diagonal 1-3.

    Examples
    --------
    >>> nodes = np.array([[0, 0, 0], [1, -0.2, 0], [2, 0, 0], [1, 0.2, 0]], float)
    >>> best_diagonal(nodes, np.array([[0, 1, 2, 3]]))
    array([ True])
    """
    return _split_quality(nodes, quads, normals=False)[0]


def best_diagonal_quality(nodes: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`best_diagonal`, and each quad's quality under that split (as
    :func:`best_split` gives it), from one pass.

    Examples
    --------
    >>> nodes = np.array([[0, 0, 0], [1, -0.2, 0], [2, 0, 0], [1, 0.2, 0]], float)
    >>> diagonal, quality = best_diagonal_quality(nodes, np.array([[0, 1, 2, 3]]))
    >>> diagonal.tolist(), bool(quality[0] == best_split(nodes, np.array([[0, 1, 2, 3]]))[1][0])
    ([True], True)
    """
    use_second, quality, _ = _split_quality(nodes, quads, normals=False)
    return use_second, quality


def split_along(quads: np.ndarray, use_second: np.ndarray, dtype: type | None = None) -> np.ndarray:
    """The two triangles of every quad, split along diagonal 1-3 where
    ``use_second``, else 0-2 (rows ``2m`` and ``2m + 1`` from quad ``m``, in
    its orientation), as ``dtype`` (default: that of ``quads``).

    Made one column at a time: no (M, 6) table of choices; in blocks of
    rows on all cores, whose columns stay in the cache (the 1 km city's 1.8
    M block faces: 0.08 s on one core).

    Examples
    --------
    >>> split_along(np.array([[0, 1, 2, 3], [4, 5, 6, 7]]), np.array([False, True])).tolist()
    [[0, 1, 2], [0, 2, 3], [5, 6, 7], [5, 7, 4]]
    """
    triangles = np.empty((len(quads), 6), dtype=dtype or quads.dtype)

    def fill(rows: slice) -> None:
        block, second_split = quads[rows], use_second[rows]
        for column, (first, second) in enumerate(zip((0, 1, 2, 0, 2, 3), (1, 2, 3, 1, 3, 0))):
            triangles[rows, column] = np.where(second_split, block[:, second], block[:, first])

    map_blocks(fill, row_blocks(len(quads), 1 << 15))
    return triangles.reshape(-1, 3)


def quad_quality(nodes: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Quality of every quad under its best split."""
    return _split_quality(nodes, quads, normals=False)[1]


def _split_quality_into(nodes: np.ndarray, quads: np.ndarray, rows: np.ndarray, quality: np.ndarray,
                        normal: np.ndarray) -> None:
    """The quality and normal (:func:`_split_quality`) of the quads ``rows``
    into the same rows of ``quality`` and ``normal``.

    Compiled, each quad is read and its results written in place
    (:func:`core.quality_kernel.split_quality_into`): no table of the quads
    gathered, nor of the results to scatter (the 1 km city's smoothing:
    0.19 -> 0.165 s over its three passes).
    """
    if jit.run("quality_kernel", "split_quality_into", nodes, quads, rows, quality, normal, size=len(rows)) is None:
        _, quality[rows], normal[rows] = _split_quality(nodes, quads.take(rows, axis=0))


def _split_quality(nodes: np.ndarray, quads: np.ndarray, block: int = 16384,
                   normals: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Which split of each quad is better, its quality, and the quad's normal.

    :func:`_split_quality_of` on ``block`` quads at a time, the blocks on all
    cores (:mod:`core.parallel`): its some fifty temporaries of one block
    stay in the cache, where on millions of quads each would stream through
    memory (and fault fresh pages in). Every number is computed
    elementwise, so the blocks give the numbers of one pass.

    Returns
    -------
    use_second : ndarray of bool (M,)
    quality : ndarray (M,)
    normal : ndarray (M, 3), or None without ``normals``
        As :func:`_split_quality_of`.
    """
    m = len(quads)
    # One compiled pass per quad, the same numbers (core.quality_kernel).
    found = jit.run("quality_kernel", "split_quality", nodes, quads, normals, size=m)
    if found is not None:
        return found
    if m <= block:
        use_second, quality, normal = _split_quality_of(nodes, quads)
        return use_second, quality, normal if normals else None
    use_second = np.empty(m, dtype=bool)
    quality = np.empty(m)
    normal = np.empty((m, 3)) if normals else None

    def fill(part: slice) -> None:
        use_second[part], quality[part], block_normal = _split_quality_of(nodes, quads[part])
        if normals:
            normal[part] = block_normal

    map_blocks(fill, row_blocks(m, block))
    return use_second, quality, normal


def _split_quality_of(nodes: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which split of each quad is better, its quality, and the quad's normal.

    The four triangles of the two splits share their six edges (four sides,
    two diagonals): each length and difference is computed once, with the
    three coordinates apart so that every operation runs on contiguous rows
    of M numbers. The arithmetic of every quantity is that of
    :func:`triangle_quality`, :func:`quad_normals` and the ``einsum`` dot
    product of the orientation test (which, in numpy 1.24, adds the x and z
    products first), so the results are the same to the last bit.

    Returns
    -------
    use_second : ndarray of bool (M,)
        Split along the diagonal 1-3 (triangles 1 2 3 and 1 3 0), else 0-2.
    quality : ndarray (M,)
    normal : ndarray (M, 3)
        As :func:`quad_normals`.
    """
    corner = quads.T
    # Gathered from the (N, 3) table: a node's three coordinates share a
    # cache line, and no copy of the N nodes is made for a few quads.
    x = coordinates(nodes, corner)  # (4, M) each

    def edge(i: int, j: int) -> list[np.ndarray]:
        return [x[c][j] - x[c][i] for c in range(3)]

    d01, d12, d23, d30, d02, d13 = edge(0, 1), edge(1, 2), edge(2, 3), edge(3, 0), edge(0, 2), edge(1, 3)
    l01, l12, l23, l30, l02, l13 = (length(d) for d in (d01, d12, d23, d30, d02, d13))
    normal = [0.5 * c for c in cross(d02, d13)]
    scale = 4 * np.sqrt(3)

    def quality(ab, bc, ca, u, v):
        # triangle_quality with sides ab, bc, ca and cross(b - a, c - a) = cross(u, v),
        # zero when the triangle faces away from the quad.
        twice_area = cross(u, v)
        area = 0.5 * length(twice_area)
        longest = np.maximum(np.maximum(ab, bc), ca)
        denominator = (ab + bc + ca) * longest
        q = np.divide(scale * area, denominator, out=np.zeros_like(area), where=denominator > 0)
        facing = dot(twice_area, normal) > 0
        return np.where(facing, q, 0.0)

    # |a - c| = |c - a| exactly, and p3 - p0 = -(p0 - p3) exactly.
    first = np.minimum(quality(l01, l12, l02, d01, d02), quality(l02, l23, l30, d02, [-c for c in d30]))
    second = np.minimum(quality(l12, l23, l13, d12, d13), quality(l13, l30, l01, d13, [-c for c in d01]))
    use_second = second > first
    return use_second, np.where(use_second, second, first), np.stack(normal, axis=1)


@dataclass
class FaceState:
    """Quality and normal (:func:`quad_quality`, :func:`quad_normals`) of
    every quad at the current node positions, where ``known``.

    Lets :func:`accept_moves` called pass after pass on the same model read
    the state a pass left instead of computing it again.
    """

    quality: np.ndarray
    normal: np.ndarray
    known: np.ndarray

    @classmethod
    def unknown(cls, n_quads: int) -> "FaceState":
        return cls(np.zeros(n_quads), np.zeros((n_quads, 3)), np.zeros(n_quads, dtype=bool))


def accept_moves(old: np.ndarray, new: np.ndarray, quads: np.ndarray, threshold: float,
                 max_rounds: int = 100,
                 is_cancelled: Callable[[], bool] | None = None,
                 state: FaceState | None = None,
                 overwrite_new: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Keep each node move only while every face around it stays acceptable.

    A face is acceptable when its quality is at least ``threshold`` (or no
    worse than before, for faces already below it) and its normal has not
    turned by more than 90 degrees. Moves of the nodes of unacceptable faces
    are undone, and the check repeats, since undoing a move changes the
    faces around that node too.

    Parameters
    ----------
    old, new : ndarray of shape (N, 3)
        Node positions before and after the proposed moves.
    quads : ndarray of int, shape (M, 4)
        Every face the nodes belong to (all regions).
    threshold : float
        Minimum face quality.
    state : FaceState, optional
        The faces at ``old`` where known: read instead of computed, and
        updated in place to the faces at the returned positions.
    overwrite_new : bool
        ``new`` is the caller's to give up: the moves are undone in it, and
        it is returned, instead of a copy (a copy of every node: 110 MB on
        the 1 km city, at the smoothing's peak of memory).

    Returns
    -------
    positions : ndarray of shape (N, 3)
    moved : ndarray of bool, shape (N,)
        Nodes whose move was kept.
    """
    moving = changed_rows(new, old)
    faces = np.flatnonzero(touching(moving, quads))
    # take and compress: row gathers faster than indexing (core.vectors).
    sub = quads.take(faces, axis=0)
    if state is None:
        _, q_old, n_old = _split_quality(old, sub)
    else:
        missing = faces[~state.known[faces]]
        if len(missing):
            _split_quality_into(old, quads, missing, state.quality, state.normal)
            state.known[missing] = True
        q_old, n_old = state.quality[faces], state.normal.take(faces, axis=0)
    floor = np.minimum(q_old, threshold)
    positions = new if overwrite_new else new.copy()
    # The faces at the current positions, for the state: a face is computed
    # again each time a move of one of its nodes is undone. The first round
    # computes them all, so its results are these tables.
    q_now, n_now = None, None
    check = np.arange(len(sub))  # faces whose nodes changed since they were checked
    for _ in range(max_rounds):
        if is_cancelled is not None and is_cancelled():
            raise Cancelled()
        if len(check) == 0:
            break
        # All the faces (the first round): no gathers of their rows.
        everything = len(check) == len(sub)
        _, q, normal = _split_quality(positions, sub if everything else sub.take(check, axis=0))
        if everything:
            q_now, n_now = q, normal
        else:
            q_now[check], n_now[check] = q, normal
        turned = np.einsum("ij,ij->i", normal, n_old if everything else n_old.take(check, axis=0)) <= 0
        bad = check[(q < (floor if everything else floor[check]) - 1e-12) | turned]
        if len(bad) == 0:
            check = check[:0]
            break
        undo = np.unique(sub.take(bad, axis=0))
        undo = undo[moving[undo]]
        positions[undo] = old.take(undo, axis=0)
        moving[undo] = False
        reverted = np.zeros(len(old), dtype=bool)
        reverted[undo] = True
        check = np.flatnonzero(touching(reverted, sub))
    if state is not None:
        if q_now is not None:  # else no round ran: every face is left unknown below
            state.quality[faces], state.normal[faces] = q_now, n_now
        state.known[faces[check]] = False  # out of rounds before their check
    return positions, moving
