"""Compiled nearest-neighbour search over data points (numba, :mod:`core.jit`).

The projection asks, for millions of nodes, their 24 nearest data points
within a radius, and for the chosen points their 12 nearest: about half of
its time in scipy's KD-tree on the 1 km synthetic city. City data are
surfaces seen from above, spread evenly: a grid of square columns, each
column's points sorted by height, finds them in half the time, and building
it takes a few tenths of a second where a KD-tree takes about a second.

:class:`ColumnIndex` answers as :func:`core.neighbours.nearest`: the ``k``
nearest points, strictly nearer than ``upper``, ordered by (distance, x, y,
z), missing ones as (``inf``, ``len(data)``). The distance is scipy's to the
last bit (squared differences summed x, y, z, then the square root), and a
point is within ``upper`` as scipy decides it (squared distance below
``upper * upper``). Where several points share a distance at the k-th place
this search is exact; :func:`core.neighbours.nearest` asks the tree for
eight more. Points with the same coordinates come by index here, in the
tree's order there: the same coordinates either way.
"""
from __future__ import annotations

import numba
import numpy as np

from .parallel import balanced_blocks, map_blocks, thread_blocks

#: Queries per call: blocks on all cores.
_BLOCK = 1 << 15
#: Fewest points sorted by column on all cores (fewer: the pool's handoffs cost more).
_PARALLEL_POINTS = 1 << 16
#: Widening of the searched box over the radius, for round-off in the columns' bounds.
BOX = 1 + 1e-9

#: How every kernel of core is compiled: cached on disk (core.jit), and without the GIL,
#: so that blocks of rows run on the pool's threads (core.parallel).
compiled = numba.njit(cache=True, nogil=True)
#: As :data:`compiled`, and inlined where called: a call that passes arrays
#: costs their reference counts, many times the work of a small helper.
inlined = numba.njit(cache=True, nogil=True, inline="always")


class ColumnIndex:
    """Data points in the columns of a square grid, each column by height.

    Parameters
    ----------
    data : ndarray (P, 3)
    cell : float
        Side of the columns: about the distance searched (a search then
        looks at a few columns).

    Examples
    --------
    >>> data = np.array([[1., 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [5, 5, 5]])
    >>> dist, idx = ColumnIndex(data, 1.0).nearest(np.zeros((1, 3)), 3)
    >>> dist.tolist(), idx.tolist()
    ([[1.0, 1.0, 1.0]], [[1, 3, 2]])
    >>> ColumnIndex(data, 1.0).nearest(np.zeros((1, 3)), 2, upper=1.0)[1].tolist()
    [[5, 5]]
    """

    #: A KD-tree over the data, made by core.neighbours.nearest if this index's search fails.
    fallback = None

    def __init__(self, data: np.ndarray, cell: float):
        self.data = np.ascontiguousarray(data, dtype=np.float64)
        n = len(self.data)
        self.x0, self.y0, self.cell, self.nx, self.ny = column_grid(self.data, cell)
        # 32-bit point numbers where they fit: 4 bytes a point less to hold.
        self.order = np.empty(n, dtype=np.int32 if n < 2**31 else np.intp)
        self.start, self.points = _bucket(self.data, self.x0, self.y0, self.cell, self.nx, self.ny, self.order)
        #: Points per unit of plan area in the columns that hold any: the data's surfaces seen from above.
        self.density = max(n, 1) / (max(int(np.count_nonzero(np.diff(self.start))), 1) * self.cell**2)

    @property
    def n(self) -> int:
        """Points indexed (as ``cKDTree.n``)."""
        return len(self.data)

    def of_first(self, data: np.ndarray) -> "ColumnIndex":
        """The index of ``data``, the first ``len(data)`` of this index's
        points (the same coordinates), made from this one without sorting
        again: its columns without the other points, which keeps each
        column's order by height.

        It answers as an index made over ``data`` would: the searches find
        the same points whatever the columns (see the module doc). The
        pipeline's final distances search the ground points this way, from
        the index the ground's projection made over them and the ground
        levels under the roofs (the 1 km city: a copy of 0.05-0.1 s on one
        core, where a new index took 0.18 s on both).

        Examples
        --------
        >>> data = np.array([[0.2, 0.2, 0.0], [0.5, 0.5, 0.0], [0.3, 0.3, 1.0], [0.4, 0.4, -1.0]])
        >>> ColumnIndex(data, 1.0).of_first(data[:2]).nearest(np.array([[0.4, 0.4, -1.0]]), 1)[1].tolist()
        [[1]]
        """
        data = np.ascontiguousarray(data, dtype=np.float64)
        if len(data) > len(self.data):
            raise ValueError(f"{len(data)} points for an index of {len(self.data)}")
        kept = self.order < len(data)
        index = ColumnIndex.__new__(ColumnIndex)
        index.data = data
        index.x0, index.y0, index.cell, index.nx, index.ny = self.x0, self.y0, self.cell, self.nx, self.ny
        # Where each column starts among the points kept: the points kept before it.
        kept_before = np.zeros(len(kept) + 1, np.int64)
        np.cumsum(kept, out=kept_before[1:])
        index.start = kept_before.take(self.start)
        del kept_before
        index.order = self.order.compress(kept)
        index.points = self.points.compress(kept, axis=1)
        index.density = max(len(data), 1) / (max(int(np.count_nonzero(np.diff(index.start))), 1) * index.cell**2)
        return index

    def nearest(self, at: np.ndarray, k: int, upper: float | np.ndarray = np.inf,
                workers: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The ``k`` nearest data points of every point ``at`` (see the module
        doc), on ``workers`` threads (default: the pool's; 1 from a thread
        of the pool, :mod:`core.parallel`). ``upper`` may also give each
        point a bound of its own (an array of one per point).

        Returns
        -------
        dist : ndarray (Q, min(k, P))
        idx : ndarray of intp (Q, min(k, P))
        """
        at = np.ascontiguousarray(at, dtype=np.float64).reshape(-1, 3)
        k = min(int(k), len(self.data))
        dist = np.empty((len(at), k))
        idx = np.empty((len(at), k), dtype=np.intp)
        if k == 0 or len(at) == 0:
            return dist, idx
        # One bound for all (an array of one) or one per point.
        upper = np.ascontiguousarray(upper, dtype=np.float64).reshape(-1)
        if len(upper) not in (1, len(at)):
            raise ValueError(f"{len(upper)} bounds for {len(at)} points")
        # The first radius of an unbounded search: about where k points lie
        # on surfaces as dense as the data, with a margin (a search that
        # finds fewer widens, twice the radius each time or, for one nearest,
        # no farther than the nearest point already seen, :func:`_nearest`,
        # and looks at its points again). On the 1 km city, the MLS planes' 12 nearest take
        # 1.09 -> 0.84 s and the nodes' nearest point 2.0 -> 1.1 s against a
        # radius of one column; the answers do not change.
        first = float(np.clip(1.3 * np.sqrt(k / (np.pi * self.density)), 0.35 * self.cell, self.cell))

        def fill(rows: slice) -> None:
            _nearest(at, rows.start, rows.stop, k, upper, first, self.x0, self.y0, self.cell, self.nx, self.ny,
                     self.order, self.start, self.points, dist, idx)

        if workers == 1:
            fill(slice(0, len(at)))
        else:
            map_blocks(fill, thread_blocks(len(at), _BLOCK))
        return dist, idx


def column_grid(xyz: np.ndarray, cell: float) -> tuple[float, float, float, int, int]:
    """Origin, side and size (x0, y0, cell, nx, ny) of a grid of columns
    ``cell`` wide over the points ``xyz`` (N, 3).

    No more columns than a few per point: sparse points over a wide extent
    (quads scattered over a city) get wider columns, which only make the
    searches look at more points, never miss one.

    Examples
    --------
    >>> column_grid(np.array([[0.0, 0, 0], [10, 4, 0]]), 2.0)
    (0.0, 0.0, 2.0, 6, 3)
    """
    if len(xyz):
        low = [float(xyz[:, c].min()) for c in range(2)]
        high = [float(xyz[:, c].max()) for c in range(2)]
    else:
        low = high = [0.0, 0.0]
    width = max(high[0] - low[0], high[1] - low[1], 0.0)
    cell = max(float(cell), 1e-9, width / np.sqrt(max(4.0 * len(xyz), 1 << 16)))
    nx = int(np.floor((high[0] - low[0]) / cell)) + 1
    ny = int(np.floor((high[1] - low[1]) / cell)) + 1
    return low[0], low[1], cell, nx, ny


def nearest_in(index: ColumnIndex, at: np.ndarray, k: int, upper: float | np.ndarray = np.inf,
               workers: int | None = None):
    """``index.nearest(at, k, upper, workers)``: for :func:`core.jit.run`."""
    return index.nearest(at, k, upper, workers)


def warm_up() -> int:
    """Compile for the types the projection passes."""
    data = np.array([[1., 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [5, 5, 5]])
    index = ColumnIndex(data, 1.0)
    assert index.nearest(np.zeros((1, 3)), 3)[1].tolist() == [[1, 3, 2]]
    assert index.nearest(np.zeros((1, 3)), 2, upper=1.5)[1].tolist() == [[1, 3]]
    return 1


def by_column(xyz: np.ndarray, rows: np.ndarray, x0: float, y0: float, cell: float, nx: int, ny: int,
              order: np.ndarray) -> np.ndarray:
    """Sort points by the column of the grid they fall in, each column's by
    height: the rows ``rows`` of ``xyz`` (N, 3), or all of them if ``rows``
    is empty, go into ``order`` (the row numbers) in that order. Returns
    where each column starts in it (nx ny + 1). Also used for the quads'
    centres by :mod:`core.crossing_kernel`.

    A counting sort on all cores: each thread counts the columns of its
    block of points, then puts them after the blocks before it in each
    column (the order of one pass), and the columns are sorted by height in
    ranges of them (the 1 km city's 7.2 M ground points: 0.26 -> 0.15 s).

    Examples
    --------
    >>> xyz = np.array([[0.5, 0.5, 2.0], [1.5, 0.2, 0.0], [0.1, 0.9, 1.0]])
    >>> order = np.empty(3, np.int64)
    >>> by_column(xyz, np.empty(0, np.int64), 0.0, 0.0, 1.0, 2, 1, order).tolist(), order.tolist()
    ([0, 2, 3], [2, 0, 1])
    """
    n = len(order)
    blocks = thread_blocks(n) if n >= _PARALLEL_POINTS else [slice(0, n)]
    key = np.empty(n, np.int64)
    # Each block's count of each column, then where its points of that column go.
    place = np.zeros((len(blocks), nx * ny), np.int64)
    map_blocks(lambda b: _column_keys(xyz, rows, blocks[b].start, blocks[b].stop, x0, y0, cell, nx, ny,
                                      key, place[b]), range(len(blocks)))
    start = np.zeros(nx * ny + 1, np.int64)
    np.cumsum(place.sum(axis=0), out=start[1:])
    _places(place, start)
    height = np.empty(n)
    map_blocks(lambda b: _scattered(xyz, rows, blocks[b].start, blocks[b].stop, key, place[b], order, height),
               range(len(blocks)))
    del key, place
    columns = thread_blocks(nx * ny) if n >= _PARALLEL_POINTS else [slice(0, nx * ny)]
    map_blocks(lambda c: _by_height(start, c.start, c.stop, order, height), columns)
    return start


@compiled
def _column_keys(xyz, rows, first, stop, x0, y0, cell, nx, ny, key, count):
    """The column of points ``first:stop`` (of ``rows``, or all) into ``key``, counted in ``count``."""
    subset = len(rows) > 0
    for i in range(first, stop):
        m = rows[i] if subset else i
        ix = min(max(int(np.floor((xyz[m, 0] - x0) / cell)), 0), nx - 1)
        iy = min(max(int(np.floor((xyz[m, 1] - y0) / cell)), 0), ny - 1)
        key[i] = ix + nx * iy
        count[key[i]] += 1


@compiled
def _places(place, start):
    """Turn each block's count of each column (rows of ``place``) into where
    its first point of that column goes: after the column's start and the
    blocks before it."""
    for c in range(place.shape[1]):
        at = start[c]
        for b in range(place.shape[0]):
            count = place[b, c]
            place[b, c] = at
            at += count


@compiled
def _scattered(xyz, rows, first, stop, key, place, order, height):
    """Points ``first:stop`` to their places in ``order``, their heights into ``height``."""
    subset = len(rows) > 0
    for i in range(first, stop):
        m = rows[i] if subset else i
        at = place[key[i]]
        order[at] = m
        height[at] = xyz[m, 2]
        place[key[i]] = at + 1


@compiled
def _by_height(start, first, stop, order, height):
    """Sort each column of ``first:stop`` by height (stable)."""
    for c in range(first, stop):
        lo, hi = start[c], start[c + 1]
        if hi - lo > 32:
            by_height = np.argsort(height[lo:hi], kind="mergesort")
            order[lo:hi] = order[lo:hi][by_height]
            height[lo:hi] = height[lo:hi][by_height]
            continue
        for i in range(lo + 1, hi):  # insertion sort: most columns hold a few points
            m, z = order[i], height[i]
            j = i - 1
            while j >= lo and height[j] > z:
                order[j + 1], height[j + 1] = order[j], height[j]
                j -= 1
            order[j + 1], height[j + 1] = m, z


@compiled
def column_range(x, y, span, x0, y0, cell, nx, ny):
    """First and last column along x, then along y, of the grid cells that
    the square of half-side ``span`` around (x, y) meets, clipped to the grid."""
    ix0 = min(max(int(np.floor((x - span - x0) / cell)), 0), nx - 1)
    ix1 = min(max(int(np.floor((x + span - x0) / cell)), 0), nx - 1)
    iy0 = min(max(int(np.floor((y - span - y0) / cell)), 0), ny - 1)
    iy1 = min(max(int(np.floor((y + span - y0) / cell)), 0), ny - 1)
    return ix0, ix1, iy0, iy1


@compiled
def rising_from(start, rows, column, low):
    """The first entry of ``column`` (sorted by height, see
    :func:`by_column`) at or above ``low``, and the column's end; the
    heights are row 2 of ``rows`` (3 or more, n). The table, not its row:
    a row taken as an array is a view made at each call, and the searches
    call this for every column they visit."""
    lo, end = start[column], start[column + 1]
    # A binary search written out: np.searchsorted on a slice made a view of
    # it and called numpy's search, many times the cost of the few steps.
    # (A NaN ``low`` gives the column's start, not its end: no height is at
    # or below a NaN bound, so the callers' scans stop at once either way.)
    hi = end
    while lo < hi:
        mid = (lo + hi) >> 1
        if rows[2, mid] < low:
            lo = mid + 1
        else:
            hi = mid
    return lo, end


def _bucket(data: np.ndarray, x0: float, y0: float, cell: float, nx: int, ny: int,
            order: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`by_column` of all the points into ``order``; returns where each
    column starts and the points' coordinates in that order (3, P)."""
    start = by_column(data, np.empty(0, np.int64), x0, y0, cell, nx, ny, order)
    points = np.empty((3, len(order)))
    map_blocks(lambda rows: _gathered_by(data, order, rows.start, rows.stop, points), balanced_blocks(len(order)))
    return start, points


@compiled
def _gathered_by(data, order, first, stop, points):
    """Rows ``order[first:stop]`` of ``data`` (P, 3) into columns ``first:stop`` of ``points`` (3, P)."""
    for t in range(first, stop):
        i = order[t]
        points[0, t], points[1, t], points[2, t] = data[i, 0], data[i, 1], data[i, 2]


@compiled
def maximum(a, b):
    """``np.maximum(a, b)`` of two floats: NaN if either is (the other kernels' too)."""
    if a != a or a >= b:
        return a
    return b


@compiled
def minimum(a, b):
    """``np.minimum(a, b)`` of two floats: NaN if either is."""
    if a != a or a <= b:
        return a
    return b


@compiled
def length(x, y, z):
    """:func:`core.vectors.length` of one vector: the x and y squares added first."""
    return np.sqrt((x * x + y * y) + z * z)


@compiled
def before(d1, x1, y1, z1, i1, d2, x2, y2, z2, i2):
    """Whether (d1, x1, y1, z1, i1) comes strictly before (d2, x2, y2, z2, i2):
    the order of :func:`core.neighbours.by_value_then_coordinates`, the
    index (column, point number) last as a stable sort keeps it."""
    if d1 != d2:
        return d1 < d2
    if x1 != x2:
        return x1 < x2
    if y1 != y2:
        return y1 < y2
    if z1 != z2:
        return z1 < z2
    return i1 < i2


@compiled
def own_column_first(x, y, x0, y0, cell, ix0, ix1, iy0, iy1):
    """For a search from (x, y) over the columns ``ix0..ix1`` by ``iy0..iy1``:
    the place of (x, y)'s own column among them (clipped to them), their
    width along x and their number, for :func:`column_in_turn`."""
    width = ix1 - ix0 + 1
    own = (min(max(int(np.floor((x - x0) / cell)), ix0), ix1) - ix0
           + width * (min(max(int(np.floor((y - y0) / cell)), iy0), iy1) - iy0))
    return own, width, width * (iy1 - iy0 + 1)


@compiled
def column_in_turn(visit, own, width, ix0, iy0):
    """The column (ix, iy) a search visits at its turn ``visit``: its own
    column first, then the others row by row. The nearest points come
    early, and the bound of the k-th found keeps most of the other columns'
    points out of the sort (the 12 nearest of 0.9 M points of the 1 km
    city: 1.85 -> 1.43 s on one core); the points found do not depend on it."""
    m = own if visit == 0 else (visit - 1 if visit - 1 < own else visit)
    return ix0 + m % width, iy0 + m // width


@compiled
def beyond(qx, qy, ix, iy, x0, y0, cell, bound2):
    """Whether every point of column (ix, iy) is farther than ``sqrt(bound2)``
    from (qx, qy, any z), by more than round-off: the distance to the column's
    square, less a billionth of its side (a point's column is the floor of a
    rounded quotient, so it may lie that little outside), against a bound
    widened as :func:`k_nearest` widens it for ties. An index's grid spans
    its data (:func:`column_grid`), so no point is clipped into a border
    column from beyond it."""
    low_x, low_y = x0 + ix * cell, y0 + iy * cell
    margin = 1e-9 * cell
    dx = max(max(low_x - qx, qx - (low_x + cell)) - margin, 0.0)
    dy = max(max(low_y - qy, qy - (low_y + cell)) - margin, 0.0)
    return dx * dx + dy * dy > bound2 * (1 + 1e-12)


@compiled
def k_nearest(qx, qy, qz, k, radius, strict, x0, y0, cell, nx, ny, order, start, points, dist, idx, key, q):
    """The k nearest within ``radius`` of (qx, qy, qz) into row ``q`` of
    ``dist`` and ``idx`` (in order, ``key`` holding their coordinates);
    within means ``d^2 < radius^2`` if ``strict``, else ``d^2 <= radius^2``.
    Returns how many were found, and the smallest squared distance of the
    points looked at beyond ``radius`` (``inf`` if none): the columns
    scanned reach past it, and for one nearest such a point bounds the
    next search (:func:`_nearest`; the bounded searches ignore it)."""
    r2 = radius * radius
    seen2 = np.inf
    box = radius * BOX
    ix0, ix1, iy0, iy1 = column_range(qx, qy, box, x0, y0, cell, nx, ny)
    kept = 0
    last2 = np.inf  # squared distance of the k-th kept
    own, width, count = own_column_first(qx, qy, x0, y0, cell, ix0, ix1, iy0, iy1)
    for visit in range(count):
        ix, iy = column_in_turn(visit, own, width, ix0, iy0)
        # A column whose every point is farther than the k-th found holds none of the k.
        if kept == k and beyond(qx, qy, ix, iy, x0, y0, cell, last2):
            continue
        t, hi = rising_from(start, points, ix + nx * iy, qz - box)
        while t < hi and points[2, t] <= qz + box:
            x, y, z = points[0, t], points[1, t], points[2, t]
            t += 1
            # scipy's sum: (0 + dx^2) + dy^2 + dz^2, in that order.
            dx, dy, dz = x - qx, y - qy, z - qz
            d2 = (dx * dx + dy * dy) + dz * dz
            if d2 > r2 or (strict and d2 == r2):
                seen2 = min(seen2, d2)
                continue
            # Beyond the k-th by more than round-off: its square root cannot tie.
            if kept == k and d2 > last2 * (1 + 1e-15):
                continue
            d = np.sqrt(d2)
            i = order[t - 1]
            slot = kept
            while slot > 0 and before(d, x, y, z, i, dist[q, slot - 1], key[slot - 1, 0],
                                       key[slot - 1, 1], key[slot - 1, 2], idx[q, slot - 1]):
                slot -= 1
            if slot >= k:
                continue
            for s in range(kept if kept < k else k - 1, slot, -1):
                dist[q, s], idx[q, s] = dist[q, s - 1], idx[q, s - 1]
                key[s, 0], key[s, 1], key[s, 2] = key[s - 1, 0], key[s - 1, 1], key[s - 1, 2]
            dist[q, slot], idx[q, slot] = d, i
            key[slot, 0], key[slot, 1], key[slot, 2] = x, y, z
            if kept < k:
                kept += 1
            if kept == k:
                last2 = dist[q, k - 1] * dist[q, k - 1]
    return kept, seen2


@compiled
def _nearest(at, start_row, stop_row, k, upper, first, x0, y0, cell, nx, ny, order, start, points, dist, idx):
    """Rows ``start_row:stop_row`` of :meth:`ColumnIndex.nearest`; ``upper``
    holds one bound for all rows or one per row."""
    n = len(order)
    key = np.empty((k, 3))
    for q in range(start_row, stop_row):
        qx, qy, qz = at[q, 0], at[q, 1], at[q, 2]
        bound = upper[0] if len(upper) == 1 else upper[q]
        if bound < np.inf:
            kept = k_nearest(qx, qy, qz, k, bound, True, x0, y0, cell, nx, ny, order, start, points, dist, idx,
                             key, q)[0]
        else:
            # Widen until the k-th found lies within the searched radius: every
            # point outside it is farther than the k-th.
            radius = first
            while True:
                kept, seen2 = k_nearest(qx, qy, qz, k, radius, False, x0, y0, cell, nx, ny, order, start, points,
                                        dist, idx, key, q)
                if (kept == k and dist[q, k - 1] <= radius) or not radius < 1e300:
                    break  # (the second: a query at infinity or NaN)
                # Twice the radius, or for one nearest no farther than a point
                # already seen (then the last search): nodes far from the data
                # (walls under roof points) end on a box as wide as that point's
                # distance, not up to twice it (the measure's search of the
                # building points: 0.53 -> 0.47 s on the 1 km city, 0.10 -> 0.086
                # s on Delft). The nudge keeps that point within the radius squared.
                radius = min(2 * radius, np.sqrt(seen2) * (1 + 1e-12)) if k == 1 else 2 * radius
        for s in range(kept, k):
            dist[q, s], idx[q, s] = np.inf, n
