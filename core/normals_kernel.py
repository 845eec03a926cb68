"""Compiled nodal normals of the projection (numba, :mod:`core.jit`, paper §4.2).

:func:`node_normals`: numpy sums the quads' unit normals into
their nodes with twelve ``bincount`` passes (a corner column and a
coordinate each), 1 s for the two projections of the 1 km synthetic city.
Here the quads' normals are made in one pass on all cores, and summed as
the ``bincount`` passes add them (per corner column, in quad order; the
columns one after the other) in passes over the quads only, so the sums are
numpy's to the last bit: 0.61 -> 0.23 s on 2.6 M lattice quads. The
projection's normals out of the blocks and the ground
(:func:`outward_node_normals`) are those sums on the model's quads as they
are, where numpy gathers and reverses each surface's faces first: the two
projections' normals on the 1 km city took 0.73-0.79 s so, 0.44-0.47 s here.
"""
from __future__ import annotations

import numpy as np

from .neighbours_kernel import compiled, length, maximum
from .parallel import balanced_blocks, map_blocks


def node_normals(nodes: np.ndarray, quads: np.ndarray, n: int) -> np.ndarray:
    """:func:`core.project.node_normals`: unit normal of every node, the mean
    of the unit normals of its quads (a zero vector where no quad touches it).

    Examples
    --------
    >>> nodes = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    >>> node_normals(nodes, np.array([[0, 1, 2, 3]]), 4)[0].tolist()
    [0.0, 0.0, 1.0]
    """
    nodes = np.ascontiguousarray(nodes, dtype=np.float64)
    quads = np.ascontiguousarray(quads)
    unit = np.empty((len(quads), 3))

    def fill(rows: slice) -> None:
        _unit_quad_normals(nodes, quads, rows.start, rows.stop, unit)

    map_blocks(fill, balanced_blocks(len(quads)))
    normal = np.zeros((n, 3))
    _sum_into_nodes(quads, unit, normal)
    return normal


def outward_node_normals(nodes: np.ndarray, quads: np.ndarray, regions: np.ndarray, on_block: np.ndarray,
                         select: np.ndarray, ground_region: int) -> np.ndarray:
    """:func:`core.project.outward_normals`: the normal of every ``select``
    node, out of its block if it is ``on_block``, else out of the ground
    (region ``ground_region``); a row per ``select`` node, in node order.

    The sums are those of :func:`node_normals` on the faces numpy gathers,
    without gathering them: the blocks' faces are the quads with a block on
    side 0 in quad order, then those with a block on side 1, reversed; the
    ground's are its quads in quad order, those with the ground on side 1
    reversed. A reversed quad's corner ``k`` is the quad's corner ``3 - k``
    and its unit normal the negated one, to the bit (its diagonals are the
    quad's, negated and swapped). So each column's pass adds, per node,
    the same terms in the same order; a node is the blocks' or the
    ground's, never both. On the 1 km synthetic city the two calls spent
    0.25 s gathering faces for 0.36 s of sums.

    Examples
    --------
    >>> nodes = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    >>> regions = np.array([[-1, 1]])  # the ground below, a block above
    >>> every = np.ones(4, bool)
    >>> outward_node_normals(nodes, np.array([[0, 1, 2, 3]]), regions, every, every, -1)[0].tolist()
    [0.0, 0.0, -1.0]
    >>> first = np.array([True, False, False, False])
    >>> outward_node_normals(nodes, np.array([[0, 1, 2, 3]]), regions, ~every, first, -1).tolist()
    [[0.0, 0.0, 1.0]]
    """
    nodes = np.ascontiguousarray(nodes, dtype=np.float64)
    quads = np.ascontiguousarray(quads)
    regions = np.ascontiguousarray(regions)
    block = np.ascontiguousarray(select & on_block)
    ground = np.ascontiguousarray(select & ~on_block)
    # Each thread lists its block of quads; the lists joined in block order are one pass's.
    parts = map_blocks(lambda rows: _outward_faces(quads, regions, block, ground, int(ground_region), rows.start,
                                                   rows.stop), balanced_blocks(len(quads)))
    if len(parts) == 1:
        first, second = parts[0]
    else:  # several blocks, or none (no quads)
        first, second = (np.concatenate([np.empty(0, np.int64)] + [part[side] for part in parts]) for side in (0, 1))
    unit = np.empty((len(quads), 3))  # rows of the faces summed only
    for faces in (first, second):
        map_blocks(lambda rows, faces=faces: _listed_unit_normals(nodes, quads, faces[rows], unit),
                   balanced_blocks(len(faces)))
    # Each wanted node's row in the sums and the result (int32: this table is
    # over every node, 18 MB on the 1 km city where int64 took 37).
    wanted = int(np.count_nonzero(select))
    slot = np.full(len(nodes), -1, dtype=np.int32)
    slot[select] = np.arange(wanted, dtype=np.int32)
    # A table per corner column; two columns summed in a pass on each thread.
    sums = np.zeros((4, wanted, 3))
    map_blocks(lambda columns: _outward_columns(quads, regions, unit, block, ground, int(ground_region), first,
                                                second, columns, slot, sums), (np.arange(2), np.arange(2, 4)))
    # Freed before the result: the ground's projection reached the run's peak of memory in this call.
    del unit, slot, first, second, faces, parts
    normal = np.empty((wanted, 3))
    map_blocks(lambda rows: _outward_total(sums, normal, rows.start, rows.stop), balanced_blocks(len(normal)))
    return normal


def warm_up() -> int:
    """Compile for the types :func:`core.project` passes."""
    nodes = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    for dtype in (np.int64, np.int32):
        normal = node_normals(nodes, np.array([[0, 1, 2, 3]], dtype=dtype), 4)
        assert normal[0].tolist() == [0.0, 0.0, 1.0], normal
        every = np.ones(4, np.bool_)
        normal = outward_node_normals(nodes, np.array([[0, 1, 2, 3]], dtype=dtype), np.array([[-1, -2]], np.int32),
                                      ~every, every, -1)
        assert normal[0].tolist() == [0.0, 0.0, 1.0], normal
    return 1


@compiled
def _unit_quad_normals(nodes, quads, start, stop, unit):
    """Rows ``start:stop`` of the quads' unit normals, as
    :func:`core.project.node_normals` makes them: half the cross product of
    the diagonals (:func:`core.quality.quad_normals`) over its length
    (:func:`core.vectors.length`, at least 1e-300)."""
    for m in range(start, stop):
        a, b, c, d = quads[m, 0], quads[m, 1], quads[m, 2], quads[m, 3]
        ux, uy, uz = nodes[c, 0] - nodes[a, 0], nodes[c, 1] - nodes[a, 1], nodes[c, 2] - nodes[a, 2]
        vx, vy, vz = nodes[d, 0] - nodes[b, 0], nodes[d, 1] - nodes[b, 1], nodes[d, 2] - nodes[b, 2]
        wx, wy, wz = 0.5 * (uy * vz - uz * vy), 0.5 * (uz * vx - ux * vz), 0.5 * (ux * vy - uy * vx)
        size = maximum(length(wx, wy, wz), 1e-300)
        unit[m, 0], unit[m, 1], unit[m, 2] = wx / size, wy / size, wz / size


@compiled
def _listed_unit_normals(nodes, quads, faces, unit):
    """The rows ``faces`` of :func:`_unit_quad_normals`."""
    for m in faces:
        _unit_quad_normals(nodes, quads, m, m + 1, unit)


@compiled
def _sum_into_nodes(quads, unit, normal):
    """Add the quads' ``unit`` normals into their nodes' ``normal`` (zeros),
    then make each sum a unit vector (zero where it is zero), with numpy's
    order of operations: per corner column, a sum over the quads in order
    (a ``bincount``), added to the total; the length as ``np.linalg.norm``.

    The first column's sums go straight into the zeros of ``normal``; the
    others through a table of zeros, each column's added into ``normal``
    once complete, and set back to zero. Adding a zero changes no sum (one
    that starts from +0.0 never becomes -0.0), so a node's sums can be added
    as often as it has quads: passes over the quads only, none over the
    model's other nodes. The nodes of no quad keep their zeros (numpy's
    division leaves +0.0 there too), so only the quads' nodes are made unit
    vectors, each once: the model has 4.8 M nodes on the 1 km city, a call's
    quads a third of them or less (0.15 -> 0.08 s for 0.3 M quads)."""
    _add_column(quads, 0, unit, normal)
    sums = np.zeros(normal.shape)
    for k in range(1, 4):
        _add_column(quads, k, unit, sums)
        _flush_column(quads, k, sums, normal)
    done = np.zeros(len(normal), np.bool_)
    for m in range(len(quads)):
        for k in range(4):
            j = quads[m, k]
            if done[j]:
                continue
            done[j] = True
            _set_unit(normal, j, normal[j, 0], normal[j, 1], normal[j, 2])


@compiled
def _add_column(quads, k, unit, into):
    """Add each quad's ``unit`` row into the row of its corner ``k``, in quad order."""
    for m in range(len(quads)):
        j = quads[m, k]
        into[j, 0] += unit[m, 0]
        into[j, 1] += unit[m, 1]
        into[j, 2] += unit[m, 2]


@compiled
def _flush_column(quads, k, sums, normal):
    """Add the ``sums`` of the corners ``k`` into ``normal`` and set them back to zero."""
    for m in range(len(quads)):
        j = quads[m, k]
        normal[j, 0] += sums[j, 0]
        normal[j, 1] += sums[j, 1]
        normal[j, 2] += sums[j, 2]
        sums[j, 0], sums[j, 1], sums[j, 2] = 0.0, 0.0, 0.0


@compiled
def _outward_faces(quads, regions, block, ground, ground_region, start, stop):
    """The faces of ``start:stop`` that :func:`outward_node_normals` sums, in
    the order it sums them: first those with a block on side 0 or the ground
    on either side, then those with a block on side 1; only those with a
    wanted corner."""
    first = np.empty(stop - start, np.int64)
    second = np.empty(stop - start, np.int64)
    n_first = n_second = 0
    for m in range(start, stop):
        a, b = regions[m, 0], regions[m, 1]
        to_block = to_ground = False
        for k in range(4):
            j = quads[m, k]
            to_block |= block[j]
            to_ground |= ground[j]
        if (a > 0 and to_block) or ((a == ground_region or b == ground_region) and to_ground):
            first[n_first] = m
            n_first += 1
        if b > 0 and to_block:
            second[n_second] = m
            n_second += 1
    return first[:n_first], second[:n_second]


@compiled
def _outward_columns(quads, regions, unit, block, ground, ground_region, first, second, columns, slot, sums):
    """The sums of the corner ``columns`` of :func:`outward_node_normals`,
    column ``k``'s into ``sums[k]`` at the rows ``slot`` of the wanted
    nodes. Each column adds in face order: a block's faces with the block
    on side 0 and the ground's faces, then a block's faces with the block on
    side 1 (reversed: their corner ``3 - k``, their normal negated)."""
    for m in first:
        a, b = regions[m, 0], regions[m, 1]
        for k in columns:
            if a > 0 and block[quads[m, k]]:
                _add_unit(sums, k, slot[quads[m, k]], unit, m, 1.0)
            if a == ground_region and ground[quads[m, k]]:
                _add_unit(sums, k, slot[quads[m, k]], unit, m, 1.0)
            elif b == ground_region and ground[quads[m, 3 - k]]:
                _add_unit(sums, k, slot[quads[m, 3 - k]], unit, m, -1.0)
    for m in second:
        for k in columns:
            if block[quads[m, 3 - k]]:
                _add_unit(sums, k, slot[quads[m, 3 - k]], unit, m, -1.0)


@compiled
def _add_unit(sums, k, w, unit, m, sign):
    """Add quad ``m``'s ``unit`` normal, times ``sign`` (1 or -1: exact), into row ``w`` of ``sums[k]``."""
    sums[k, w, 0] += sign * unit[m, 0]
    sums[k, w, 1] += sign * unit[m, 1]
    sums[k, w, 2] += sign * unit[m, 2]


@compiled
def _outward_total(sums, normal, start, stop):
    """The columns' sums added as :func:`_sum_into_nodes` adds them, made a
    unit vector (zero where zero) in the rows ``start:stop`` of ``normal``."""
    for w in range(start, stop):
        x = ((sums[0, w, 0] + sums[1, w, 0]) + sums[2, w, 0]) + sums[3, w, 0]
        y = ((sums[0, w, 1] + sums[1, w, 1]) + sums[2, w, 1]) + sums[3, w, 1]
        z = ((sums[0, w, 2] + sums[1, w, 2]) + sums[2, w, 2]) + sums[3, w, 2]
        _set_unit(normal, w, x, y, z)


@compiled
def _set_unit(normal, j, x, y, z):
    """Row ``j`` of ``normal``: (x, y, z) over its length, zeros where that
    is zero (numpy's division where the length is positive, on zeros)."""
    size = length(x, y, z)
    if size > 0:
        normal[j, 0], normal[j, 1], normal[j, 2] = x / size, y / size, z / size
    else:
        normal[j, 0], normal[j, 1], normal[j, 2] = 0.0, 0.0, 0.0
