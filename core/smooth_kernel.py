"""Compiled vertex-only Catmull-Clark step (numba, :mod:`core.jit`), and the
nodes' roles that constrain it.

A step of :class:`core.smooth.CatmullClarkStep` is four sparse products
(face centres, their sums at the nodes, edge midpoints, theirs), a weighted
sum of three (n, 3) tables, then the rows of the nodes that follow the
surface copied into the new positions: 1 s for the three passes of the
1 km synthetic city. Here the centres and midpoints are made on all cores,
summed into the nodes in one pass each, and the weighted sums written
straight into the new positions. The sums run in scipy's order (the
products of ``csr_matvecs`` and ``csc_matvecs``: a centre from zero, corner
by corner; a node's sum from zero, face by face, then edge by edge), and
the weights as numpy's expression, so the positions are the same to the
last bit; the tests compare both.
"""
from __future__ import annotations

import numpy as np

from .neighbours_kernel import compiled
from .parallel import balanced_blocks, map_blocks


def step_into(target: np.ndarray, positions: np.ndarray, nodes: np.ndarray, which: np.ndarray,
              face_corners: np.ndarray, edge_ends: np.ndarray, face_weight: np.ndarray,
              edge_weight: np.ndarray, own_weight: np.ndarray) -> np.ndarray:
    """Write the step's new positions of the surface nodes ``nodes[which]`` into ``target``.

    Parameters
    ----------
    target, positions : ndarray (N, 3)
        New and current positions of the model's nodes.
    nodes : ndarray of int (S,)
        The surface's nodes; the tables below number them ``0..S-1``.
    which : ndarray of bool (S,)
        Surface nodes whose new position is wanted.
    face_corners, edge_ends : ndarray of int (4 F,), (2 E,)
        Each face's four corners, each edge's two ends, one after the other.
    face_weight, edge_weight, own_weight : ndarray (S,)
        The weights of a node's summed face centres, summed edge midpoints
        and position.

    Returns
    -------
    target

    Examples
    --------
    The corner of a cube of side 2 (as :class:`core.smooth.CatmullClarkStep`):

    >>> from core.smooth import CatmullClarkStep
    >>> nodes = np.array([[x, y, z] for z in (0, 2) for y in (0, 2) for x in (0, 2)], float)
    >>> cube = np.array([[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4],
    ...                  [1, 3, 7, 5], [3, 2, 6, 7], [2, 0, 4, 6]])
    >>> step = CatmullClarkStep(cube, 8)
    >>> target = step.into(nodes.copy(), nodes, np.ones(8, bool))
    >>> target[0].round(8).tolist()
    [0.44444444, 0.44444444, 0.44444444]
    """
    positions = np.ascontiguousarray(positions, dtype=np.float64)
    size = len(nodes)
    faces = (face_corners, 4, 0.25, _centres_of(positions, nodes, face_corners, 4, 0.25))
    edges = (edge_ends, 2, 0.5, _centres_of(positions, nodes, edge_ends, 2, 0.5))
    # A node's sum runs in face (edge) order, one pass each: the two share
    # nothing, so each runs on a thread of its own (the 1 km city's three
    # passes: 0.26 s of these sums, on one core one after the other).
    face_sum, edge_sum = map_blocks(lambda table: _summed(*table, size), (faces, edges))
    map_blocks(lambda rows: _combine(target, positions, nodes, which, face_sum, edge_sum, face_weight,
                                     edge_weight, own_weight, rows.start, rows.stop),
               balanced_blocks(size))
    return target


def _centres_of(positions: np.ndarray, nodes: np.ndarray, corners: np.ndarray, per: int,
                weight: float) -> np.ndarray:
    """The weighted centres of the faces (or edges) ``corners``, on all cores."""
    count = len(corners) // per
    centre = np.empty((count, 3))
    map_blocks(lambda rows: _centres(positions, nodes, corners, per, weight, rows.start, rows.stop, centre),
               balanced_blocks(count))
    return centre


def _summed(corners: np.ndarray, per: int, weight: float, centre: np.ndarray, size: int) -> np.ndarray:
    """Each surface node's sum of the ``centre`` of its faces (or edges), in one pass in face order."""
    total = np.zeros((size, 3))
    _sum_centres(corners, per, weight, centre, total)
    return total


def node_roles(quads: np.ndarray, regions: np.ndarray, nodes: np.ndarray, lower: np.ndarray, upper: np.ndarray,
               tol: float, ground: int, air: int, outside: int) -> tuple[np.ndarray, ...]:
    """The masks of :meth:`core.smooth.NodeRoles.of` in one pass over the
    quads and one over the nodes, where numpy makes some twenty passes and
    four compressed copies of the quads (0.43 s on the 1 km synthetic city).

    Returns
    -------
    on_block, on_ground, foot, fixed_axes, movable
        As :class:`core.smooth.NodeRoles`.
    """
    n = len(nodes)
    on_block, on_ground = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    on_ground_air, inside = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    _mark_roles(quads, regions, ground, air, outside, on_block, on_ground, on_ground_air, inside)
    foot = on_block & on_ground_air
    fixed_axes = np.empty((n, 3), dtype=bool)
    movable = np.empty(n, dtype=bool)
    _fix_axes(np.ascontiguousarray(nodes, dtype=np.float64), np.asarray(lower, dtype=np.float64),
              np.asarray(upper, dtype=np.float64), float(tol), foot, on_block, on_ground, inside,
              fixed_axes, movable)
    return on_block, on_ground, foot, fixed_axes, movable


#: Nodes per bucket of :func:`undirected_edges`' first pass (a power of two):
#: a bucket's counts, insertion points and edges stay in the cache.
_BUCKET_NODES = 1 << 12


@compiled
def undirected_edges(faces, size):
    """:func:`core.smooth.undirected_edges`: each node's edges to higher nodes
    by a counting sort on the lower end, each node's few sorted by insertion
    and its repeats dropped, instead of a sort of every key: the same rows.

    The counting sort runs in two passes, as a radix sort: the edges into
    buckets of :data:`_BUCKET_NODES` consecutive lower ends, then each
    bucket by its lower ends, in a table of its own. In one pass over all
    the nodes, the counts and insertion points were tables as long as the
    nodes, met at random by consecutive faces (7 M nodes at 0.5 m: 1.5-2.4
    s, most of it cache misses). The edges kept are written back over the
    buckets already read, then once into the result."""
    m, corners = faces.shape
    shift = 0
    while (1 << shift) < _BUCKET_NODES:
        shift += 1
    width, buckets = 1 << shift, (size >> shift) + 1
    start = np.zeros(buckets + 1, np.int64)
    for f in range(m):
        for c in range(corners):
            a, b = faces[f, c], faces[f, (c + 1) % corners]
            start[(min(a, b) >> shift) + 1] += 1
    largest = 0
    for k in range(buckets):
        largest = max(largest, start[k + 1])
        start[k + 1] += start[k]
    fill = start[:-1].copy()
    low_of = np.empty(corners * m, faces.dtype)
    high_of = np.empty(corners * m, faces.dtype)
    for f in range(m):
        for c in range(corners):
            a, b = faces[f, c], faces[f, (c + 1) % corners]
            low = min(a, b)
            k = low >> shift
            low_of[fill[k]], high_of[fill[k]] = low, max(a, b)
            fill[k] += 1
    first_of = np.zeros(width + 1, np.int64)  # where each node's edges start in the bucket
    at = np.empty(width, np.int64)
    high = np.empty(largest, faces.dtype)  # a bucket's higher ends, by lower end
    e = 0  # edges kept: written over the buckets already read
    for k in range(buckets):
        begin, stop, base = start[k], start[k + 1], k << shift
        first_of[:] = 0
        for q in range(begin, stop):
            first_of[low_of[q] - base + 1] += 1
        for v in range(width):
            first_of[v + 1] += first_of[v]
        at[:] = first_of[:-1]
        for q in range(begin, stop):
            v = low_of[q] - base
            high[at[v]] = high_of[q]
            at[v] += 1
        for v in range(min(width, size - base)):
            first, last = first_of[v], first_of[v + 1]
            for q in range(first + 1, last):
                x = high[q]
                p = q - 1
                while p >= first and high[p] > x:
                    high[p + 1] = high[p]
                    p -= 1
                high[p + 1] = x
            for q in range(first, last):
                if q == first or high[q] != high[q - 1]:
                    low_of[e], high_of[e] = base + v, high[q]
                    e += 1
    ends = np.empty(2 * e, faces.dtype)
    for i in range(e):
        ends[2 * i], ends[2 * i + 1] = low_of[i], high_of[i]
    return ends


def warm_up() -> int:
    """Compile for the types :class:`core.smooth.CatmullClarkStep` passes
    (its tables are int32, int64 on very large surfaces, as scipy's index arrays)."""
    from .smooth import CatmullClarkStep

    nodes = np.array([[x, y, z] for z in (0, 2) for y in (0, 2) for x in (0, 2)], float)
    cube = np.array([[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [1, 3, 7, 5], [3, 2, 6, 7], [2, 0, 4, 6]])
    step = CatmullClarkStep(cube, 8)
    expected = step(nodes)
    for dtype in (np.int32, np.int64):  # unique_nodes numbers the faces' corners in either
        assert undirected_edges(cube.astype(dtype), 8).reshape(-1, 2).tolist()[:3] == [[0, 1], [0, 2], [0, 4]]
    for dtype in (np.int32, np.int64):
        corners, ends, *weights = step.tables()
        target = step_into(np.zeros_like(nodes), nodes, step.nodes, np.ones(8, bool), corners.astype(dtype),
                           ends.astype(dtype), *weights)
        assert np.array_equal(target, expected), target
    regions = np.array([[1, -1], [1, -2], [-2, -1], [-1, -3]], dtype=np.int32)
    for dtype in (np.int32, np.int64):
        roles = node_roles(cube[:4].astype(dtype), regions, nodes, np.zeros(3), np.full(3, 2.0), 1e-9, -2, -1, -3)
        assert [int(mask.sum()) for mask in roles] == [8, 6, 4, 24, 0], roles
    return 1


@compiled
def _centres(positions, nodes, corners, per, weight, start, stop, centre):
    """Centres ``start:stop`` (rows of ``csr_matvecs``: from zero, corner by corner)."""
    for f in range(start, stop):
        x, y, z = 0.0, 0.0, 0.0
        for c in range(f * per, f * per + per):
            i = nodes[corners[c]]
            x += weight * positions[i, 0]
            y += weight * positions[i, 1]
            z += weight * positions[i, 2]
        centre[f, 0], centre[f, 1], centre[f, 2] = x, y, z


@compiled
def _sum_centres(corners, per, weight, centre, total):
    """Add each face's weighted centre into its corners' ``total``, face by
    face (the columns of ``csc_matvecs``)."""
    for f in range(len(centre)):
        for c in range(f * per, f * per + per):
            i = corners[c]
            total[i, 0] += weight * centre[f, 0]
            total[i, 1] += weight * centre[f, 1]
            total[i, 2] += weight * centre[f, 2]


@compiled
def _combine(target, positions, nodes, which, face_sum, edge_sum, face_weight, edge_weight, own_weight,
             start, stop):
    """Surface nodes ``start:stop``: ``face_weight * face_sum + edge_weight *
    edge_sum + own_weight * p`` (numpy's order) into ``target`` where ``which``."""
    for s in range(start, stop):
        if not which[s]:
            continue
        i = nodes[s]
        for c in range(3):
            target[i, c] = (face_weight[s] * face_sum[s, c] + edge_weight[s] * edge_sum[s, c]) \
                + own_weight[s] * positions[i, c]


@compiled
def _mark_roles(quads, regions, ground, air, outside, on_block, on_ground, on_ground_air, inside):
    """Mark the nodes of the block faces, the ground faces, the faces
    between ground and air, and the faces inside the domain."""
    for m in range(len(quads)):
        a, b = regions[m, 0], regions[m, 1]
        block = a > 0 or b > 0
        ground_face = a == ground or b == ground
        ground_air = (a == ground and b == air) or (a == air and b == ground)
        inner = a != outside and b != outside
        for k in range(4):
            j = quads[m, k]
            if block:
                on_block[j] = True
            if ground_face:
                on_ground[j] = True
            if ground_air:
                on_ground_air[j] = True
            if inner:
                inside[j] = True


@compiled
def _fix_axes(nodes, lower, upper, tol, foot, on_block, on_ground, inside, fixed_axes, movable):
    """The coordinates each node keeps (on a plane of the domain's box, and
    the foot's z) and whether it moves at all, as NodeRoles.of computes them."""
    for j in range(len(nodes)):
        every = True
        for c in range(3):
            fixed = abs(nodes[j, c] - lower[c]) < tol or abs(nodes[j, c] - upper[c]) < tol
            if c == 2:
                fixed = fixed or foot[j]
            fixed_axes[j, c] = fixed
            every = every and fixed
        movable[j] = (on_block[j] or on_ground[j]) and inside[j] and not every
