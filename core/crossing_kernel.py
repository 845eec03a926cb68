"""Compiled crossing search of the projection (numba, :mod:`core.jit`).

The crossing control (:mod:`core.intersect`) asks, for the quads around the
moved nodes (the seeds), which of their triangles cross a triangle they
share no node with. Its numpy code lists the close quad pairs with KD-trees,
then filters and tests the pairs a block at a time, some twenty whole-array
passes; on the 1 km synthetic city that is 8 M quad pairs and most of the
projection's time. Here both phases run in one compiled pass over the seeds,
without pair lists:

- Broad phase: the quads are bucketed by the column of a square grid their
  centre falls in, each column's quads sorted by the height of their centre,
  in two tiers (the quads whose reach is up to a high quantile, and the few
  larger ones: a stretched face must not widen every search). A seed looks
  up, in each tier, the columns and heights within its own reach plus the
  tier's largest, and keeps the quads whose balls meet its ball (centres
  closer than the reaches added up, with the numpy code's 1e-9 margin).
  A pair of two seeds is taken from the one with the smaller index only.
- Narrow phase: the four triangle pairs of each quad pair go through
  :func:`core.intersect._crossing_of`'s filters (no shared node, a triangle
  in focus, overlapping float32 boxes) and :func:`core.intersect._edges_cross`,
  written scalar by scalar with the same operations in the same order.

The numpy code's broad phase keeps more pairs (every pair within the sum of
its size classes' largest reaches): it finds no crossing in them, since two
triangles that cross lie in quad balls that meet. So both find the same
crossing pairs, in another order; :func:`core.intersect.undo_crossings` uses
them as a set. The tests compare the two on shaken stacked grids and on the
district, and the cities give the same models either way.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from .errors import Cancelled
from .neighbours_kernel import by_column, column_grid, column_range, compiled, length, maximum, minimum, rising_from
from .parallel import balanced_blocks, map_blocks, row_blocks

#: Quantile of the reach that splits the quads into the two tiers.
_TIER_QUANTILE = 0.99
#: Seeds searched per call (a block per thread at a time; cancel is checked between blocks).
_SEED_BLOCK = 1 << 15
#: Relative margin on the sum of two reaches, as the numpy broad phase's radii.
_MARGIN = 1 + 1e-9


def crossing_triangles(centre: np.ndarray, reach: np.ndarray, seeds: np.ndarray, tri: np.ndarray,
                       positions: np.ndarray, rows: tuple[np.ndarray, np.ndarray], in_focus: np.ndarray,
                       is_cancelled: Callable[[], bool] | None = None,
                       searched: Callable[[int], None] | None = None) -> np.ndarray:
    """Crossing triangle pairs (P, 2), the triangle in focus first.

    Parameters
    ----------
    centre, reach : ndarray (S, 3), (S,)
        Balls of the quads searched (:func:`core.intersect._balls`).
    seeds : ndarray of int
        Rows of ``centre`` whose triangles are tested against all the others.
    tri : ndarray of int (2 S, 3)
        Triangle ``2 q + k`` is triangle ``k`` of quad ``q``; node indices
        into ``positions`` (N, 3).
    rows : (lower, upper)
        The triangles' float32 boxes (:func:`core.intersect._pair_rows`).
    in_focus : ndarray of bool (2 S,)
        Triangles whose crossings count; a pair needs one.
    searched : callable, optional
        Told the number of seeds of every block searched, from the thread
        that searched it (for a progress bar).

    Returns
    -------
    ndarray of int64 (P, 2)
        Triangle indices into ``tri``; the order of the pairs is not defined.

    Examples
    --------
    Two unit squares 0.5 apart, a corner of the lower pushed through the upper:

    >>> positions = np.array([[0.3, 0.3, 1.0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
    ...                       [0, 0, 0.5], [1, 0, 0.5], [1, 1, 0.5], [0, 1, 0.5]])
    >>> tri = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]], dtype=np.int32)
    >>> from core.intersect import _balls, _pair_rows
    >>> centre, reach = _balls(positions, np.array([[0, 1, 2, 3], [4, 5, 6, 7]]))
    >>> in_focus = np.array([True, True, False, False])
    >>> pairs = crossing_triangles(centre, reach, np.array([0]), tri, positions,
    ...                            _pair_rows(positions, tri), in_focus)
    >>> sorted(map(tuple, pairs.tolist()))
    [(0, 2), (1, 3)]
    """
    found = [np.zeros((0, 2), dtype=np.int64)]
    if len(seeds) == 0 or len(centre) == 0:
        return found[0]
    centre = np.ascontiguousarray(centre, dtype=np.float64)
    reach = np.ascontiguousarray(reach, dtype=np.float64)
    is_seed = np.zeros(len(centre), dtype=bool)
    is_seed[seeds] = True
    small_reach = float(np.quantile(reach, _TIER_QUANTILE))
    small = reach <= small_reach
    # Columns twice the small tier's reach wide: a small quad's search spans
    # two or three of them along each axis.
    x0, y0, cell, nx, ny = column_grid(centre, 2 * small_reach)
    tiers = []
    for members in (np.flatnonzero(small), np.flatnonzero(~small)):
        order, start, ball = _bucket(members, centre, reach, x0, y0, cell, nx, ny)
        tiers.append((order, start, ball, float(reach[members].max()) if len(members) else 0.0))
    lower, upper = rows
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    seeds = np.ascontiguousarray(seeds, dtype=np.int64)

    def search(part: slice) -> np.ndarray:
        if is_cancelled is not None and is_cancelled():
            raise Cancelled()
        pairs = _search(seeds[part], centre, reach, is_seed, x0, y0, cell, nx, ny,
                        *tiers[0], *tiers[1], positions, tri, lower, upper, in_focus)
        if searched is not None:
            searched(part.stop - part.start)
        return pairs

    found.extend(map_blocks(search, row_blocks(len(seeds), _SEED_BLOCK)))
    return np.concatenate(found)


def face_balls(nodes: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre and reach of every face, as :func:`core.intersect._balls`
    (the corners summed in their order, then divided by their number; the
    largest squared distance to a corner, its square root), on all cores.

    Examples
    --------
    >>> nodes = np.array([[0.0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0]])
    >>> centre, reach = face_balls(nodes, np.array([[0, 1, 2, 3]]))
    >>> centre.tolist(), reach.round(6).tolist()
    ([[1.0, 1.0, 0.0]], [1.414214])
    """
    nodes = np.ascontiguousarray(nodes, dtype=np.float64)
    faces = np.ascontiguousarray(faces)
    centre = np.empty((len(faces), 3))
    reach = np.empty(len(faces))
    map_blocks(lambda rows: _balls(nodes, faces, rows.start, rows.stop, centre, reach), balanced_blocks(len(faces)))
    return centre, reach


def triangle_boxes(nodes: np.ndarray, tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The triangles' float32 boxes rounded outwards, as per-axis rows
    (3, T): :func:`core.intersect._pair_rows`, on all cores.

    Examples
    --------
    >>> lower, upper = triangle_boxes(np.array([[0.1, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    >>> lower.dtype.name, bool(lower[0, 0] <= 0.1), bool(upper[0, 0] >= 1.0)
    ('float32', True, True)
    """
    nodes = np.ascontiguousarray(nodes, dtype=np.float64)
    tri = np.ascontiguousarray(tri)
    lower = np.empty((3, len(tri)), dtype=np.float32)
    upper = np.empty((3, len(tri)), dtype=np.float32)
    map_blocks(lambda rows: _boxes(nodes, tri, rows.start, rows.stop, lower, upper), balanced_blocks(len(tri)))
    return lower, upper


def warm_up() -> int:
    """Compile for the types :func:`core.intersect._crossing_quads` passes
    (32-bit triangles): two plates, a node pushed through the upper one."""
    from .intersect import _balls, _pair_rows

    positions = np.array([[0.3, 0.3, 1.0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                          [0, 0, 0.5], [1, 0, 0.5], [1, 1, 0.5], [0, 1, 0.5]])
    tri = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]], dtype=np.int32)
    centre, reach = _balls(positions, np.array([[0, 1, 2, 3], [4, 5, 6, 7]]))
    pairs = crossing_triangles(centre, reach, np.array([0]), tri, positions, _pair_rows(positions, tri),
                               np.array([True, True, False, False]))
    assert len(pairs) == 2, pairs
    for dtype in (np.int64, np.int32):
        centre, reach = face_balls(positions, np.array([[0, 1, 2, 3], [4, 5, 6, 7]], dtype=dtype))
        assert np.array_equal(centre[1], [0.5, 0.5, 0.5]), centre
        lower, upper = triangle_boxes(positions, tri.astype(dtype))
        assert lower[2, 0] == 0.0 and upper[2, 0] == 1.0, (lower, upper)
    return len(pairs)


@compiled
def _balls(nodes, faces, start, stop, centre, reach):
    """Rows ``start:stop`` of :func:`face_balls`."""
    corners = faces.shape[1]
    for f in range(start, stop):
        a = faces[f, 0]
        x, y, z = nodes[a, 0], nodes[a, 1], nodes[a, 2]
        for k in range(1, corners):
            b = faces[f, k]
            x, y, z = x + nodes[b, 0], y + nodes[b, 1], z + nodes[b, 2]
        x, y, z = x / corners, y / corners, z / corners
        squared = 0.0
        for k in range(corners):
            b = faces[f, k]
            dx, dy, dz = nodes[b, 0] - x, nodes[b, 1] - y, nodes[b, 2] - z
            squared = maximum(squared, (dx * dx + dy * dy) + dz * dz)
        centre[f, 0], centre[f, 1], centre[f, 2] = x, y, z
        reach[f] = np.sqrt(squared)


@compiled
def _boxes(nodes, tri, start, stop, lower, upper):
    """Rows ``start:stop`` of :func:`triangle_boxes`: each bound rounded to
    float32, then one float32 step outwards where the rounding went inwards."""
    down, up = np.float32(-np.inf), np.float32(np.inf)
    for t in range(start, stop):
        a, b, c = tri[t, 0], tri[t, 1], tri[t, 2]
        for axis in range(3):
            x0, x1, x2 = nodes[a, axis], nodes[b, axis], nodes[c, axis]
            low = minimum(minimum(x0, x1), x2)
            high = maximum(maximum(x0, x1), x2)
            low32, high32 = np.float32(low), np.float32(high)
            lower[axis, t] = np.nextafter(low32, down) if low32 > low else low32
            upper[axis, t] = np.nextafter(high32, up) if high32 < high else high32


def _bucket(members: np.ndarray, centre: np.ndarray, reach: np.ndarray, x0: float, y0: float, cell: float,
            nx: int, ny: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``members`` by column, each column's by height
    (:func:`core.neighbours_kernel.by_column`): the members in that order,
    where each column starts in it (nx ny + 1), and the members' centres
    (3, n) and reaches in that order (a search reads them in a run)."""
    order = np.empty(len(members), np.int64)
    start = by_column(centre, members, x0, y0, cell, nx, ny, order)
    ball = np.empty((4, len(order)))
    map_blocks(lambda rows: _balls_by(order, centre, reach, rows.start, rows.stop, ball), balanced_blocks(len(order)))
    return order, start, ball


@compiled
def _balls_by(order, centre, reach, first, stop, ball):
    """Centres and reaches of the quads ``order[first:stop]`` into columns ``first:stop`` of ``ball``."""
    for i in range(first, stop):
        m = order[i]
        ball[0, i], ball[1, i], ball[2, i], ball[3, i] = centre[m, 0], centre[m, 1], centre[m, 2], reach[m]


@compiled
def _edges_cross(positions, tri, edges_of, face):
    """Whether an edge of triangle ``edges_of`` crosses triangle ``face``
    (rows of ``tri``): :func:`core.intersect._edges_cross` for one pair, each
    operation as there (``vectors.dot`` sums x and z first). Rows, not the
    node triples: a row of ``tri`` taken as an array is a view made per call
    (the 1 km city's search 2.78 -> 2.62-2.66 s on one core)."""
    f0, f1, f2 = tri[face, 0], tri[face, 1], tri[face, 2]
    v0x, v0y, v0z = positions[f0, 0], positions[f0, 1], positions[f0, 2]
    e1x, e1y, e1z = positions[f1, 0] - v0x, positions[f1, 1] - v0y, positions[f1, 2] - v0z
    e2x, e2y, e2z = positions[f2, 0] - v0x, positions[f2, 1] - v0y, positions[f2, 2] - v0z
    scale = 1e-12 * maximum(length(e1x, e1y, e1z) * length(e2x, e2y, e2z), 1e-300)
    eps = 1e-9
    for i in range(3):
        j = (i + 1) % 3  # the edges (0, 1), (1, 2), (2, 0)
        ei, ej = tri[edges_of, i], tri[edges_of, j]
        ox, oy, oz = positions[ei, 0], positions[ei, 1], positions[ei, 2]
        dx, dy, dz = positions[ej, 0] - ox, positions[ej, 1] - oy, positions[ej, 2] - oz
        hx, hy, hz = dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x
        det = (e1x * hx + e1z * hz) + e1y * hy
        if not abs(det) > scale * maximum(length(dx, dy, dz), 1e-300):
            continue  # numpy's inv is 0 there, and no hit
        inv = 1.0 / det
        sx, sy, sz = ox - v0x, oy - v0y, oz - v0z
        u = inv * ((sx * hx + sz * hz) + sy * hy)
        qx, qy, qz = sy * e1z - sz * e1y, sz * e1x - sx * e1z, sx * e1y - sy * e1x
        v = inv * ((dx * qx + dz * qz) + dy * qy)
        t = inv * ((e2x * qx + e2z * qz) + e2y * qy)
        if u > eps and v > eps and u + v < 1 - eps and t > eps and t < 1 - eps:
            return True
    return False


@compiled
def _search(seeds, centre, reach, is_seed, x0, y0, cell, nx, ny,
            order0, start0, ball0, reach0, order1, start1, ball1, reach1,
            positions, tri, lower, upper, in_focus):
    """The crossing triangle pairs of ``seeds`` (see :func:`crossing_triangles`)."""
    out = np.empty((64, 2), np.int64)
    n = 0
    for s in range(len(seeds)):
        a = seeds[s]
        ax, ay, az, ra = centre[a, 0], centre[a, 1], centre[a, 2], reach[a]
        for tier in range(2):
            if tier == 0:
                order, start, ball, tier_reach = order0, start0, ball0, reach0
            else:
                order, start, ball, tier_reach = order1, start1, ball1, reach1
            if len(order) == 0:
                continue
            span = (ra + tier_reach) * _MARGIN
            ix0, ix1, iy0, iy1 = column_range(ax, ay, span, x0, y0, cell, nx, ny)
            for iy in range(iy0, iy1 + 1):
                for ix in range(ix0, ix1 + 1):
                    i, hi = rising_from(start, ball, ix + nx * iy, az - span)
                    while i < hi and ball[2, i] <= az + span:
                        dx, dy, dz = ball[0, i] - ax, ball[1, i] - ay, ball[2, i] - az
                        limit = (ra + ball[3, i]) * _MARGIN
                        b = order[i]
                        i += 1
                        if b == a or (is_seed[b] and b < a):
                            continue  # a pair of seeds is searched from its first one
                        if not dx * dx + dy * dy + dz * dz <= limit * limit:
                            continue
                        # The four triangle pairs of the two quads, written out here: as a
                        # function of its own, the call (seven arrays passed, one returned)
                        # cost more than the tests (1.7 of the 1 km city's 2.6 s on one core).
                        for ka in range(2):
                            ta = 2 * a + ka
                            for kb in range(2):
                                tb = 2 * b + kb
                                shared = False
                                for u in range(3):
                                    for v in range(3):
                                        shared |= tri[ta, u] == tri[tb, v]
                                if shared or not (in_focus[ta] or in_focus[tb]):
                                    continue
                                overlap = True
                                for c in range(3):
                                    overlap &= lower[c, ta] <= upper[c, tb] and lower[c, tb] <= upper[c, ta]
                                if not overlap:
                                    continue
                                if _edges_cross(positions, tri, ta, tb) or _edges_cross(positions, tri, tb, ta):
                                    if n == len(out):
                                        grown = np.empty((2 * len(out), 2), np.int64)
                                        grown[:n] = out
                                        out = grown
                                    first, second = (ta, tb) if in_focus[ta] else (tb, ta)
                                    out[n, 0], out[n, 1] = first, second
                                    n += 1
    return out[:n].copy()
