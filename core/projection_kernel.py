"""Compiled step 1 of the projection (numba, :mod:`core.jit`): the data
points a node tries; its normal is :mod:`core.normals_kernel`'s.

Among a node's 24 nearest
data points, the few closest to the line through the node along its normal,
ties broken by the points' coordinates. numpy does it with a (Q, 24) table
of distances, a partial sort, a sort of the first few columns and a full
lexsort of the rows with ties: 1.3 s for the 5 M nodes of the 1 km synthetic
city. Here each row is one pass that keeps its best few in order, with the
arithmetic of :func:`core.project._distance_to_line` operation for operation
and the order of :func:`core.project._ranked` (distance, then x, y, z, then
the column), so the chosen points are the same; the tests compare both.
Over a compiled index of the data (:class:`core.neighbours_kernel.ColumnIndex`),
:func:`candidates_near_lines` also finds the 24 nearest in that pass,
without their table: on the same city the index's nearest points then
this pass took 1.3-1.5 s for the 1.5 M building nodes and 1.4-1.5 s for
the 0.95 M ground nodes, the one pass 0.86-0.96 s and 1.07-1.11 s (wall
time on 2 cores, the same points).
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from .errors import Cancelled
from .neighbours_kernel import BOX, before, column_range, compiled, inlined, length, rising_from
from .parallel import map_blocks, thread_blocks

#: Nodes per call of the fused search (blocks on all cores).
_BLOCK = 1 << 14
#: The fused search's first radius over the radius of a disc that holds k
#: points of the data's density (:func:`candidates_near_lines`): 1.1-1.3 did
#: as well on the 1 km city (ground 0.72-0.75 -> 0.49-0.58 s, buildings
#: 0.56-0.65 -> 0.51-0.58 s), smaller ones send more nodes to the whole radius.
_NEAR_RADIUS = 1.2
#: Share of the latest nodes (a decaying mean) with too few points inside the
#: first radius above which the fused search takes the whole radius at once.
_MOSTLY_MISSED = 0.25


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


def candidates_near_lines(index, p: np.ndarray, normal: np.ndarray, k: int, radius: float,
                          tries: int, near: float | None = None,
                          is_cancelled: Callable[[], bool] | None = None,
                          done: Callable[[int], None] | None = None) -> np.ndarray:
    """The ``tries`` of the ``k`` nearest data points of each node within
    ``radius`` that lie closest to the line through it along its normal:
    ``closest_to_lines(index.data, index.nearest(p, k, radius)[1], p, normal, tries)``,
    in one pass per node over the points of its columns.

    Those two steps write and read back a (Q, k) table of distances and one
    of indices (365 MB for the ground nodes of the 1 km synthetic city).
    Here each node's points within the radius go to rows of scratch, and
    the few closest to the line among its k nearest are picked from them
    (:func:`_near_lines`): the same k points, the same few chosen (by
    distance to the line, then x, y, z, then the point number, which for
    points at the same coordinates is the order of the row).

    Parameters
    ----------
    index : core.neighbours_kernel.ColumnIndex
        Over the data points.
    p, normal : ndarray (Q, 3)
    k : int
        Nearest points among which to choose.
    radius : float
        Points strictly within it only.
    tries : int
    near : float, optional
        A first radius (default: where k points lie on surfaces as dense
        as the data, widened by ``_NEAR_RADIUS``): a node with more than k
        points inside it takes its k nearest among them, and only those
        points are weighed (about 30 within it, 50 within the radius on the
        1 km city's ground). Where most nodes lately had too few inside it
        (walls, edges), the whole radius is searched from the start; the
        points chosen are the same either way.
    is_cancelled : callable, optional
        Checked before each block of nodes: :class:`core.errors.Cancelled`
        is raised if it returns True. All the nodes may come in one call,
        whose blocks the pool's threads take in turn: a call per batch of
        nodes left a thread idle at the end of each (0.10-0.16 s on the 1 km
        city in batches of 131 k nodes).
    done : callable, optional
        ``done(count)`` after each block, with its number of nodes, from the
        thread that ran it (:func:`core.progress.counted`).

    Returns
    -------
    ndarray of intp (Q, min(tries, k, P))
        Data point indices, closest to the line first; ``len(data)`` where
        fewer points are found.

    Examples
    --------
    >>> from core.neighbours_kernel import ColumnIndex
    >>> data = np.array([[3.0, 4.0, 7.0], [0.0, 0.0, -2.0], [0.0, 1.0, 5.0]])
    >>> index = ColumnIndex(data, 1.0)
    >>> candidates_near_lines(index, np.zeros((1, 3)), np.array([[0.0, 0, 1]]), 4, 10.0, 2)
    array([[1, 2]])
    >>> candidates_near_lines(index, np.zeros((1, 3)), np.array([[0.0, 0, 1]]), 4, 3.0, 2)
    array([[1, 3]])
    """
    p = np.ascontiguousarray(p, dtype=np.float64).reshape(-1, 3)
    normal = np.ascontiguousarray(normal, dtype=np.float64).reshape(-1, 3)
    k = min(int(k), index.n)
    out = np.empty((len(p), min(int(tries), k)), dtype=np.intp)
    if k == 0 or len(p) == 0:
        return out

    if near is None:
        near = _NEAR_RADIUS * np.sqrt(k / (np.pi * index.density))
    near = min(float(radius), float(near))

    def fill(rows: slice) -> None:
        if is_cancelled is not None and is_cancelled():
            raise Cancelled()
        _near_lines(p, normal, rows.start, rows.stop, k, float(radius), near, index.x0, index.y0, index.cell,
                    index.nx, index.ny, index.order, index.start, index.points, out)
        if done is not None:
            done(rows.stop - rows.start)

    map_blocks(fill, thread_blocks(len(p), _BLOCK))
    return out


def warm_up() -> int:
    """Compile for the types :func:`core.project` passes."""
    data = np.array([[3.0, 4.0, 7.0], [0.0, 0.0, -2.0], [0.0, 1.0, 5.0]])
    out = closest_to_lines(data, np.array([[0, 1, 2, 3]]), np.zeros((1, 3)), np.array([[0.0, 0, 1]]), 2)
    assert out.tolist() == [[1, 2]], out
    from .neighbours_kernel import ColumnIndex

    out = candidates_near_lines(ColumnIndex(data, 1.0), np.zeros((1, 3)), np.array([[0.0, 0, 1]]), 4, 3.0, 2)
    assert out.tolist() == [[1, 3]], out
    return 1


@compiled
def _off_line(x, y, z, px, py, pz, nx, ny, nz):
    """Distance of (x, y, z) to the line through p along n, as
    :func:`core.project._distance_to_line` computes it (``vectors.dot`` sums
    x and z first, ``vectors.length`` x and y)."""
    ox, oy, oz = x - px, y - py, z - pz
    along = (ox * nx + oz * nz) + oy * ny
    ex, ey, ez = ox - along * nx, oy - along * ny, oz - along * nz
    return length(ex, ey, ez)


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


@compiled
def _near_lines(at, normal, start_row, stop_row, k, radius, near, x0, y0, cell, nx, ny, order, start, points,
                out):
    """Rows ``start_row:stop_row`` of :func:`candidates_near_lines`.

    Each node's points strictly within the radius go to rows of scratch
    with their distances to the node and to the line; only those well
    inside ``near`` where more than k are (searched within ``near`` first,
    unless that lately failed for most nodes). The few closest to
    the line are then taken in turn among all of them, each kept if it is
    among the k nearest (fewer than k come before it in the order of
    :func:`core.neighbours_kernel.k_nearest`: distance, x, y, z, point
    number): on surfaces the points nearest the line are near the node, and
    every one taken is. Where one is not (a node whose line runs along the
    surface), the k nearest are selected (:func:`_select_nearest`) and the
    few closest to the line taken among them. Either way the points are
    those of the k nearest then the few closest to the line, in the order
    of :func:`_closest`.

    Keeping each node's k nearest sorted as they came, then ranking them by
    the line, took three quarters of the pass: on the 1 km city's ground
    nodes, 48 points within the radius of each, a third of them inserted
    with 6.5 shifts on average (300 k nodes on one core: 0.61-0.68 s; the
    scan of the columns alone 0.12 s).
    """
    n, tries = len(order), out.shape[1]
    size = 64
    dist, line = np.empty(size), np.empty(size)
    px, py, pz = np.empty(size), np.empty(size), np.empty(size)
    point, rank = np.empty(size, np.int64), np.empty(size, np.int64)
    best_key = np.empty((tries, 4))
    best_point = np.empty(tries, np.int64)
    inner2 = (near * (1 - 1e-12)) * (near * (1 - 1e-12))
    misses = 0.0  # how often, lately, too few points lay inside ``near``
    for q in range(start_row, stop_row):
        qx, qy, qz = at[q, 0], at[q, 1], at[q, 2]
        n0, n1, n2 = normal[q, 0], normal[q, 1], normal[q, 2]
        reach = near if misses < _MOSTLY_MISSED else radius
        while True:
            r2, box = reach * reach, reach * BOX
            ix0, ix1, iy0, iy1 = column_range(qx, qy, box, x0, y0, cell, nx, ny)
            most = 0
            for iy in range(iy0, iy1 + 1):
                most += start[ix1 + 1 + nx * iy] - start[ix0 + nx * iy]
            if most > size:
                size = 2 * most
                dist, line = np.empty(size), np.empty(size)
                px, py, pz = np.empty(size), np.empty(size), np.empty(size)
                point, rank = np.empty(size, np.int64), np.empty(size, np.int64)
            # The points within reach: those well inside ``near`` from the
            # front of the scratch, the others from its back, squared distances.
            inner, outer = 0, 0
            for iy in range(iy0, iy1 + 1):
                for ix in range(ix0, ix1 + 1):
                    t, hi = rising_from(start, points, ix + nx * iy, qz - box)
                    while t < hi and points[2, t] <= qz + box:
                        x, y, z = points[0, t], points[1, t], points[2, t]
                        t += 1
                        # scipy's sum, as k_nearest: (0 + dx^2) + dy^2 + dz^2.
                        dx, dy, dz = x - qx, y - qy, z - qz
                        d2 = (dx * dx + dy * dy) + dz * dz
                        if d2 >= r2:
                            continue
                        if d2 < inner2:
                            h = inner
                            inner += 1
                        else:
                            outer += 1
                            h = size - outer
                        dist[h], px[h], py[h], pz[h], point[h] = d2, x, y, z, order[t - 1]
            misses = 0.9 * misses + (0.1 if inner <= k else 0.0)
            if inner > k or reach == radius:
                break
            reach = radius
        if inner > k:
            # The k nearest are among these: every other point is farther
            # than ``near`` by more than round-off, so its distance (a
            # square root) ties with none of theirs, and none of the others
            # can be chosen or counted below.
            found = inner
        else:
            for j in range(outer):
                h = size - 1 - j
                dist[inner + j], px[inner + j], py[inner + j], pz[inner + j] = dist[h], px[h], py[h], pz[h]
                point[inner + j] = point[h]
            found = inner + outer
        for h in range(found):
            dist[h] = np.sqrt(dist[h])
            line[h] = _off_line(px[h], py[h], pz[h], qx, qy, qz, n0, n1, n2)
            rank[h] = h
        kept = 0
        if found > k:
            # The closest to the line first, while each is among the k nearest.
            left = found
            while kept < tries:
                b = 0
                for h in range(1, left):
                    if _nearer(rank[h], rank[b], line, px, py, pz, point):
                        b = h
                c = rank[b]
                # How many come before it: a count without branches, then the ties.
                nearer, equal, dc = 0, 0, dist[c]
                for m in range(found):
                    nearer += dist[m] < dc
                    equal += dist[m] == dc
                if equal > 1:
                    for m in range(found):
                        if dist[m] == dc and m != c and _nearer(m, c, dist, px, py, pz, point):
                            nearer += 1
                if nearer >= k:
                    break
                best_point[kept] = point[c]
                kept += 1
                left -= 1
                rank[b], rank[left] = rank[left], c
            if kept < tries:
                kept = 0
                for h in range(found):
                    rank[h] = h
                _select_nearest(rank, found, k, dist, px, py, pz, point)
                found = k
        if kept == 0:
            for h in range(found):
                m = rank[h]
                d, x, y, z, i = line[m], px[m], py[m], pz[m], point[m]
                # Inserted in order as _closest does, written out here too: as
                # a function of its own (arrays passed in), the insertion made
                # _closest five times slower and this pass a fifth slower. The
                # order is total (the point number last): the points may come
                # in any order.
                slot = kept
                while slot > 0 and before(d, x, y, z, i, best_key[slot - 1, 0], best_key[slot - 1, 1],
                                          best_key[slot - 1, 2], best_key[slot - 1, 3], best_point[slot - 1]):
                    slot -= 1
                if slot >= tries:
                    continue
                for s in range(kept if kept < tries else tries - 1, slot, -1):
                    best_point[s] = best_point[s - 1]
                    best_key[s, 0], best_key[s, 1] = best_key[s - 1, 0], best_key[s - 1, 1]
                    best_key[s, 2], best_key[s, 3] = best_key[s - 1, 2], best_key[s - 1, 3]
                best_point[slot] = i
                best_key[slot, 0], best_key[slot, 1], best_key[slot, 2], best_key[slot, 3] = d, x, y, z
                if kept < tries:
                    kept += 1
        for s in range(tries):
            out[q, s] = best_point[s] if s < kept else n


@inlined
def _nearer(a, b, key, px, py, pz, point):
    """Whether found point ``a`` comes before ``b`` by ``key`` (their distances to the node, or
    to its line), then x, y, z and point number (:func:`core.neighbours_kernel.before`)."""
    return before(key[a], px[a], py[a], pz[a], point[a], key[b], px[b], py[b], pz[b], point[b])


@inlined
def _select_nearest(rank, count, k, dist, px, py, pz, point):
    """Reorder ``rank[:count]`` (found points) so that its first ``k`` are the
    k nearest, in any order: a quickselect on a total order, so the k are
    those a sort would put first."""
    lo, hi = 0, count - 1
    while lo < hi:
        mid = (lo + hi) >> 1
        # The median of the first, middle and last as the pivot.
        if _nearer(rank[mid], rank[lo], dist, px, py, pz, point):
            rank[mid], rank[lo] = rank[lo], rank[mid]
        if _nearer(rank[hi], rank[lo], dist, px, py, pz, point):
            rank[hi], rank[lo] = rank[lo], rank[hi]
        if _nearer(rank[hi], rank[mid], dist, px, py, pz, point):
            rank[hi], rank[mid] = rank[mid], rank[hi]
        pivot = rank[mid]
        i, j = lo, hi
        while i <= j:
            while _nearer(rank[i], pivot, dist, px, py, pz, point):
                i += 1
            while _nearer(pivot, rank[j], dist, px, py, pz, point):
                j -= 1
            if i <= j:
                rank[i], rank[j] = rank[j], rank[i]
                i += 1
                j -= 1
        # rank[lo:j + 1] come before the pivot or are it, rank[i:hi + 1] after or it.
        if k - 1 <= j:
            hi = j
        elif k - 1 >= i:
            lo = i
        else:
            break
