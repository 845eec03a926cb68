"""Nearest-neighbour searches over data points, with answers that do not depend
on the search tree.

Every search of the method goes through a :func:`search_tree`. A KD-tree
that is not balanced and not compacted is built about three times faster
(0.16 s instead of 0.45 s for 2.2 M ground points of the synthetic city)
and answers as fast; distances do not depend on the tree's shape, and the
one thing that does, the order of points at equal distances, is settled by
coordinates (:func:`nearest`). Tiles, with trees over other points, then
find what a single run finds.

A query runs on :func:`core.parallel.thread_count` threads (scipy's
``workers=-1`` would take every core of the machine in each Dask worker, and
in each thread of a row-block pool), a small one on the calling thread
(:func:`query_threads`).
"""
from __future__ import annotations

from concurrent.futures import Future
from typing import TYPE_CHECKING, Callable, Sequence, Union

import numpy as np
from scipy.spatial import cKDTree

from . import jit
from .parallel import in_background, row_blocks, thread_count

if TYPE_CHECKING:  # imports numba: only where a kernel runs (core.jit)
    from .neighbours_kernel import ColumnIndex

#: What the searches take: a KD-tree, or with numba a compiled index of columns (:func:`point_index`).
PointSearch = Union[cKDTree, "ColumnIndex"]

#: Points times neighbours below which a KD-tree search runs on the calling thread
#: (:func:`query_threads`). scipy starts its threads anew at every call: 0.1-0.2 ms each on
#: an idle machine, more than a small search gains (12 neighbours of 1,000 points: 3.0 ms on
#: one thread, 2.8 ms on two; of 16,000: 59 and 26 ms), and milliseconds when the cores are
#: busy (another process, QGIS, a Dask worker beside): Zurich's CityJSON, one small grid per
#: building, took 8.9-10.1 s with two other processes busy, 5.7-7.0 s so.
SMALL_QUERY = 12_000

#: :func:`nearest_distance`'s first search, in at most this many parts of at
#: least so many points, each told to its ``progress``; and that search's
#: share of its time (the others search near the points only).
DISTANCE_PARTS, DISTANCE_PART_ROWS, FIRST_SEARCH_SHARE = 8, 1 << 17, 0.75


def query_threads(n_points: int, k: int, wanted: int | None = None) -> int:
    """Threads for a KD-tree search of the ``k`` nearest of ``n_points``
    points: one for a small search (:data:`SMALL_QUERY`), else ``wanted``
    (default :func:`core.parallel.thread_count`). The answers do not depend on it.

    Examples
    --------
    >>> query_threads(100, 12), query_threads(100_000, 12, wanted=2)
    (1, 2)
    """
    if n_points * k < SMALL_QUERY:
        return 1
    return wanted or thread_count()


def search_tree(points: np.ndarray) -> cKDTree:
    """A KD-tree over ``points`` for nearest-neighbour, ball and pair searches.

    Examples
    --------
    >>> search_tree(np.array([[0.0, 0, 0], [3, 4, 0]])).query([0.0, 0, 1])[0]
    1.0
    """
    return cKDTree(points, balanced_tree=False, compact_nodes=False)


def point_index(data: np.ndarray, cell: float, tree: PointSearch | None = None) -> PointSearch:
    """What :func:`nearest` searches ``data`` with: with numba, a compiled
    index of columns ``cell`` wide (:class:`core.neighbours_kernel.ColumnIndex`,
    twice as fast, built in a tenth of the time); else ``tree``, or a new
    :func:`search_tree`.

    Examples
    --------
    >>> data = np.array([[1., 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]])
    >>> nearest(point_index(data, 1.0), data, np.zeros((1, 3)), 2)[1].tolist()
    [[1, 3]]
    """
    if tree is not None and not isinstance(tree, cKDTree):
        return tree  # already an index
    index = jit.run("neighbours_kernel", "ColumnIndex", data, cell, size=len(data))
    if index is not None:
        return index
    return tree if tree is not None else search_tree(data)


def search_of_first(search: PointSearch, data: np.ndarray, cell: float) -> PointSearch | Future:
    """A search over ``data``, the first rows of the data ``search`` was made
    over: from a compiled index, the same index without the other rows
    (:meth:`core.neighbours_kernel.ColumnIndex.of_first`); else
    :func:`point_index` of ``data``, made on a thread of its own (a future,
    as :func:`nearest_distance` takes it).

    Examples
    --------
    >>> data = np.array([[0.0, 0, 0], [1, 0, 0], [0.2, 0, 0]])
    >>> first = search_of_first(point_index(data, 1.0), data[:2], 1.0)
    >>> first = first.result() if isinstance(first, Future) else first
    >>> nearest(first, data[:2], np.array([[0.3, 0, 0]]), 1)[1].tolist()
    [[0]]
    """
    if isinstance(search, cKDTree):
        return in_background(point_index, data, cell)
    return search.of_first(data)


def kd_tree(search: PointSearch, data: np.ndarray) -> cKDTree:
    """The KD-tree of a search over ``data``: the search itself, or for a
    compiled index whose kernel failed (:func:`core.jit.run`), a tree built
    once and kept on it.

    Examples
    --------
    >>> tree = search_tree(np.zeros((2, 3)))
    >>> kd_tree(tree, np.zeros((2, 3))) is tree
    True
    """
    if isinstance(search, cKDTree):
        return search
    if search.fallback is None:
        search.fallback = search_tree(data)
    return search.fallback


def nearest(tree: PointSearch, data: np.ndarray, at: np.ndarray, k: int,
            upper: float | np.ndarray = np.inf, spare: int = 8,
            workers: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` nearest data points of every point ``at``, ties broken by coordinates.

    A KD-tree returns points at equal distances in the order it visits them,
    which depends on all the data it holds: the ``k`` kept are the nearest,
    then the smallest in (x, y, z). One more neighbour is asked for first;
    where it is as near as the ``k``-th, more points may share that
    distance, and ``spare`` more are asked for. Missing neighbours (beyond
    ``upper``) have distance ``inf`` and index ``len(data)``. The search runs
    on ``workers`` threads (default :func:`core.parallel.thread_count`; 1
    from a thread of the row-block pool), a small one on one
    (:func:`query_threads`). ``tree`` may also be a compiled
    index (:func:`point_index`), which gives the same answers. ``upper``
    may give each point a bound of its own; a KD-tree then searches within
    the largest, and may return points beyond a point's own bound.

    Examples
    --------
    >>> data = np.array([[1., 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]])
    >>> dist, idx = nearest(search_tree(data), data, np.zeros((1, 3)), 2)
    >>> data[idx[0]].tolist()
    [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]
    """
    if not isinstance(tree, cKDTree):
        # A compiled column index (point_index): the same answers.
        found = jit.run("neighbours_kernel", "nearest_in", tree, at, k, upper, workers)
        if found is not None:
            return found
        tree = kd_tree(tree, data)  # the kernel failed (core.jit.run)
    upper = _largest(upper)
    k = min(k, len(data))
    workers = query_threads(len(at), k, workers)
    out_dist, out_idx = _nearest_of(tree, data, at, k, min(k + 1, len(data)), upper, workers)
    if 0 < k < len(data):
        # The (k+1)-th as near as the k-th (both found): the points at that
        # distance may be more than the tree gave.
        tied = np.flatnonzero((out_dist[:, k] == out_dist[:, k - 1]) & (out_dist[:, k] != np.inf))
        out_dist, out_idx = out_dist[:, :k].copy(), out_idx[:, :k].copy()
        if len(tied):
            dist, idx = _nearest_of(tree, data, at.take(tied, axis=0), k, min(k + spare, len(data)), upper,
                                    workers)
            out_dist[tied], out_idx[tied] = dist[:, :k], idx[:, :k]
    return out_dist, out_idx


def _largest(upper: float | np.ndarray) -> float:
    """The bound a KD-tree searches within: ``upper``, or the largest of a bound per point."""
    return float(np.max(upper, initial=0.0)) if np.ndim(upper) else float(upper)


def _nearest_of(tree: cKDTree, data: np.ndarray, at: np.ndarray, k: int, m: int,
                upper: float, workers: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``m`` nearest of every point ``at``, the first ``k`` ordered by
    (distance, x, y, z) among them. Returns C-contiguous (Q, m) arrays."""
    dist, idx = tree.query(at, k=m, distance_upper_bound=upper, workers=workers)
    dist = dist.reshape(len(at), m)
    idx = idx.reshape(len(at), m)
    # The tree lists neighbours by increasing distance, the missing ones
    # (inf, len(data)) last. A row whose found distances strictly increase
    # is already in the order the sort below gives (the missing entries are
    # all alike): only the other rows, usually few, are sorted. The outputs
    # keep the memory layout of the sorted arrays (einsum's rounding follows it).
    earlier, later = dist[:, :-1], dist[:, 1:]
    unsure = np.flatnonzero((~(later > earlier) & (later != np.inf)).any(axis=1))
    if len(unsure):
        # take and compress: row gathers faster than indexing (core.vectors).
        d, i = dist.take(unsure, axis=0), idx.take(unsure, axis=0)
        order = by_value_then_coordinates(d, i, data, k)
        dist[unsure, :k] = np.take_along_axis(d, order, axis=1)
        idx[unsure, :k] = np.take_along_axis(i, order, axis=1)
    return dist, idx


def by_value_then_coordinates(value: np.ndarray, index: np.ndarray, data: np.ndarray, k: int) -> np.ndarray:
    """Columns of the ``k`` smallest ``value`` of every row, ties broken by the
    (x, y, z) of the data points ``index`` (``len(data)`` for a missing one,
    whose value is ``inf``): an order that does not depend on the KD-tree."""
    point = data.take(np.minimum(index, len(data) - 1), axis=0)
    return np.lexsort((point[..., 2], point[..., 1], point[..., 0], value), axis=1)[:, :k]


def nearest_distance(points: np.ndarray, trees: Sequence, bound: float,
                     maybe_within: Sequence[Callable[[np.ndarray, float], np.ndarray] | None] | None = None,
                     progress: Callable[[float], None] | None = None) -> np.ndarray:
    """Distance from every point to the nearest point of any tree's data (NaN without data).

    A tree may also be a compiled index (:func:`point_index`): the same
    distances. A tree after the first may be a future of one (being made on
    another thread, :func:`core.parallel.in_background`): it is waited for
    when its turn comes, once the first is searched.

    The first tree is searched in full. The others first only within
    ``bound``, a search that stops early; where the nearest point so far is
    farther than ``bound`` and they found nothing, within that distance.
    The minimum is the distance a search of all the data at once finds: the
    trees over the parts are built once for other steps, and a tree over
    their union (10 M points on a city) is not.

    ``maybe_within`` may give, for a tree after the first, a function of
    points and a distance: the mask of the points that may have one of its
    data points within that distance. The others are known to have none and
    skip that search (roofs and walls high above the ground,
    :class:`core.ground.NearGround`).

    ``progress(share)`` is told the share of the work done, as the first
    search goes (1.79 M block nodes took 0.7-0.9 s on the 1 km city) and
    when it ends.

    Examples
    --------
    >>> near, far = search_tree(np.array([[0.0, 0, 1]])), search_tree(np.array([[0.0, 0, -5]]))
    >>> nearest_distance(np.array([[0.0, 0, 0], [0, 0, -4]]), [near, far], 0.5).tolist()
    [1.0, 1.0]
    >>> may_reach_far = lambda points, reach: points[:, 2] - reach <= -5
    >>> nearest_distance(np.array([[0.0, 0, 0], [0, 0, -4]]), [near, far], 0.5, [None, may_reach_far]).tolist()
    [1.0, 1.0]
    """
    distance = np.full(len(points), np.inf)
    searched = False
    for n, tree in enumerate(trees):
        if isinstance(tree, Future):
            tree = tree.result()
        if tree.n == 0 or len(points) == 0:
            continue
        if not searched:
            distance = np.empty(len(points))
            for rows in row_blocks(len(points), max(DISTANCE_PART_ROWS, -(-len(points) // DISTANCE_PARTS))):
                distance[rows] = nearest_within(tree, points[rows], np.inf)
                if progress is not None:
                    progress(FIRST_SEARCH_SHARE * rows.stop / len(points))
            searched = True
            continue
        maybe = maybe_within[n] if maybe_within is not None else None

        def within(rows: np.ndarray | None, limit: float, tree=tree, maybe=maybe) -> np.ndarray:
            where = points if rows is None else points.take(rows, axis=0)
            # A point of this tree counts only if nearer than the nearest
            # found so far: each point searches no farther than that (the same
            # minimum; on the 1 km city the ground's searches 0.38 -> 0.11 s).
            upper = np.minimum(limit, distance if rows is None else distance.take(rows))
            if maybe is None:
                return nearest_within(tree, where, upper)
            found = np.full(len(where), np.inf)
            some = np.flatnonzero(maybe(where, limit))
            found[some] = nearest_within(tree, where.take(some, axis=0), upper.take(some))
            return found

        found = within(None, bound)
        # Nothing within bound, and nothing that near so far: searched again
        # within bounds four times wider each time, each point as far as its
        # distance so far (a farther point would not be the nearest). Points
        # far from all the data (a roof above the ground) make a full search
        # slow.
        pending = np.flatnonzero(np.isinf(found) & (distance > bound))
        limit = max(bound, 1e-300)
        while len(pending):
            limit *= 4
            now = distance[pending] <= limit
            if now.any():
                found[pending[now]] = within(pending[now], limit)
            pending = pending[~now]
        np.minimum(distance, found, out=distance)
    distance[np.isinf(distance)] = np.nan
    if progress is not None:
        progress(1.0)
    return distance


def nearest_within(tree, points: np.ndarray, upper: float | np.ndarray) -> np.ndarray:
    """Distance from every point to the nearest data point strictly within
    ``upper`` (``inf`` if none), through a KD-tree or a compiled index
    (:func:`point_index`): the same distances. With a bound per point, a
    KD-tree searches within the largest, and may find points beyond a
    point's own bound (for a caller that keeps the smaller of the two).

    Examples
    --------
    >>> tree = search_tree(np.array([[0.0, 0, 1], [0, 0, 3]]))
    >>> nearest_within(tree, np.array([[0.0, 0, 0], [0, 0, 9]]), 2.0).tolist()
    [1.0, inf]
    """
    if isinstance(tree, cKDTree):
        return tree.query(points, k=1, distance_upper_bound=_largest(upper), workers=query_threads(len(points), 1))[0]
    return nearest(tree, tree.data, points, 1, upper)[0][:, 0].copy()
