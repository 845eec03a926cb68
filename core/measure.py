"""Per-block measures of the final meshes: volume, areas, quality, distance to data.

Everything is computed for all blocks at once from the faces of the
:class:`~core.surface.SurfaceModel`, with ``bincount`` over the block that
owns each face. Roofs and facades are told apart by the face normal (paper
§1: "facades and rooves can also be identified"): a face is a facade when
its normal is within ``facade_tilt`` degrees of horizontal, a roof when it
points up more steeply than that; faces pointing down (the block's base on
the ground, the underside of an overhang) are neither.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import jit
from .blocks import BlockRows
from .parallel import map_blocks, row_blocks
from .quality import best_diagonal_quality, quad_quality, split_along
from .surface import SurfaceModel
from .vectors import coordinates, cross, dot, length, minus

#: Triangles measured at a time (a few MB of temporaries).
_ROWS = 1 << 16


@dataclass
class BlockMeasures(BlockRows):
    """Mesh measures of blocks ``1..n`` (arrays of length n, CRS units)."""

    volume: np.ndarray
    area: np.ndarray
    roof_area: np.ndarray
    facade_area: np.ndarray
    min_quality: np.ndarray
    mean_quality: np.ndarray
    mean_dist: np.ndarray
    max_dist: np.ndarray


def block_face_split(model: SurfaceModel, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The best split (:func:`core.quality.best_diagonal_quality`) of every
    face between a block and another region, in the model's order, at
    ``nodes``: whether along its diagonal 1-3, and its quality.

    Examples
    --------
    >>> from core.grid import VoxelGrid
    >>> g = VoxelGrid(np.zeros(3), np.zeros(3), 2.0, (1, 1, 3))
    >>> s = SurfaceModel.from_regions(g, np.array([-1, 1, -2], np.int32).reshape(1, 1, 3))
    >>> diagonal, quality = block_face_split(s, s.nodes)
    >>> len(diagonal), round(float(quality.min()), 4)
    (6, 0.7174)
    """
    # take and compress: row gathers faster than indexing (core.vectors).
    return best_diagonal_quality(nodes, model.quads.compress(model.on_block(), axis=0))


def measure_blocks(model: SurfaceModel, nodes: np.ndarray, n_blocks: int,
                   node_distance: np.ndarray | None = None,
                   facade_tilt: float = 30.0,
                   split: tuple[np.ndarray, np.ndarray] | None = None) -> BlockMeasures:
    """Volume, areas, face quality and node-to-data distance of every block.

    Parameters
    ----------
    model : SurfaceModel
        Topology (quads, regions).
    nodes : ndarray (N, 3)
        Node positions to measure (voxel, smoothed or projected).
    n_blocks : int
    node_distance : ndarray (N,), optional
        Distance of every node to the data; NaN measures when omitted.
    facade_tilt : float
        Largest angle (degrees) between a facade normal and the horizontal.
    split : tuple of ndarray, optional
        :func:`block_face_split` of ``model`` at ``nodes``, when the caller has it.

    Examples
    --------
    One voxel block of side 2 on the ground:

    >>> from core.grid import VoxelGrid
    >>> g = VoxelGrid(np.zeros(3), np.zeros(3), 2.0, (1, 1, 3))
    >>> s = SurfaceModel.from_regions(g, np.array([-1, 1, -2], np.int32).reshape(1, 1, 3))
    >>> m = measure_blocks(s, s.nodes, 1)
    >>> m.volume, m.roof_area, m.facade_area
    (array([8.]), array([4.]), array([16.]))
    """
    moved = SurfaceModel(nodes=nodes, quads=model.quads, regions=model.regions)
    quads, owner = moved.block_faces()
    # The triangles of the block faces as SurfaceModel.triangulated splits
    # them (on the model's orientation), without splitting the other faces;
    # the quality of each face as the block sees it (a face the model orients
    # into the block is judged reversed).
    a = model.regions[:, 0]
    block = np.flatnonzero(model.on_block())
    # take and compress: row gathers faster than indexing (core.vectors).
    block_quads = model.quads.take(block, axis=0)
    diagonal, split_quality = split if split is not None else best_diagonal_quality(nodes, block_quads)
    outward = a[block] > 0
    quality = np.concatenate([split_quality[outward], quad_quality(nodes, quads[outward.sum():])])
    limit = np.sin(np.radians(facade_tilt))
    # The same sums in two compiled passes over the faces (core.measure_kernel).
    sums = jit.run("measure_kernel", "triangle_sums", nodes, block_quads, diagonal, outward, owner, n_blocks, limit,
                   size=2 * len(block))
    if sums is None:
        sums = triangle_sums(nodes, block_quads, diagonal, outward, owner, n_blocks, limit)
    six_volume, area, roof_area, facade_area = (total[1:] for total in sums)

    def per_block(weights: np.ndarray, owners: np.ndarray) -> np.ndarray:
        return np.bincount(owners, weights=weights, minlength=n_blocks + 1)[1:]

    quad_count = np.bincount(owner, minlength=n_blocks + 1)[1:]
    min_quality = extreme_per_block(owner, quality, n_blocks, largest=False)
    if node_distance is None:
        mean_dist = max_dist = np.full(n_blocks, np.nan)
    else:
        # Each node once per block: the (block, node) pairs, by block then node.
        n_nodes = len(nodes)
        node_block = np.zeros(n_nodes, dtype=np.int64)
        node_block[quads] = owner[:, None]
        if np.array_equal(node_block[quads], np.broadcast_to(owner[:, None], quads.shape)):
            # Blocks share no node (well-composed voxels): each node has one
            # block, and its pair comes without sorting them all.
            pair_node = np.flatnonzero(node_block)
            pair_block = node_block[pair_node]
        else:
            pairs = np.unique(np.repeat(owner, 4).astype(np.int64) * n_nodes + quads.ravel())
            pair_block, pair_node = pairs // n_nodes, pairs % n_nodes
        d = node_distance[pair_node]
        per_node = np.bincount(pair_block, minlength=n_blocks + 1)[1:]
        mean_dist = per_block(d, pair_block) / np.maximum(per_node, 1)
        max_dist = extreme_per_block(pair_block, d, n_blocks, largest=True, initial=0.0)[1:]
    return BlockMeasures(
        volume=six_volume / 6.0,
        area=area,
        roof_area=roof_area,
        facade_area=facade_area,
        min_quality=min_quality[1:],
        mean_quality=per_block(quality, owner) / np.maximum(quad_count, 1),
        mean_dist=mean_dist,
        max_dist=max_dist,
    )


def triangle_sums(nodes: np.ndarray, quads: np.ndarray, use_second: np.ndarray, outward: np.ndarray,
                  owner: np.ndarray, n_blocks: int, limit: float) -> tuple[np.ndarray, ...]:
    """Per-block sums over the triangles of the block faces: six times the
    signed volume to a per-block reference point, the area, and the area of
    the roof and of the facade triangles (n_blocks + 1 each).

    The faces ``quads`` (as the model orients them) are split along the
    diagonal 1-3 where ``use_second``, else 0-2 (:func:`core.quality.split_along`);
    the triangles of the faces ``outward`` from their block come first, then
    the others reversed; ``owner`` is the block of each face in that order.
    A triangle is a roof where its normal's z is at least ``limit``, a facade
    where its absolute value is below it. :mod:`core.measure_kernel` makes
    the same sums in two compiled passes, without the table of triangles.

    Examples
    --------
    A unit cube's six faces, oriented out of block 1:

    >>> nodes = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    >>> quads = np.array([[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]])
    >>> n = len(quads)
    >>> sums = triangle_sums(nodes, quads, np.zeros(n, bool), np.ones(n, bool), np.ones(n, np.int64), 1, 0.5)
    >>> [round(float(s[1]), 9) for s in sums]  # six times the volume, area, roof, facades
    [6.0, 6.0, 1.0, 4.0]
    """
    split = split_along(quads, use_second).reshape(-1, 2, 3)
    triangles = np.concatenate([split.compress(outward, axis=0).reshape(-1, 3),
                                split.compress(~outward, axis=0).reshape(-1, 3)[:, ::-1]])
    tri_owner = np.repeat(owner, 2)
    # Signed volume of the tetrahedra to a per-block reference point (any
    # point works for a closed surface; a nearby one keeps round-off small).
    count = np.bincount(tri_owner, minlength=n_blocks + 1)
    first = coordinates(nodes, triangles[:, 0])
    reference = np.column_stack([np.bincount(tri_owner, weights=first[c], minlength=n_blocks + 1)
                                 for c in range(3)]) / np.maximum(count, 1)[:, None]
    del first
    tri_area, six_v, nz = np.empty(len(triangles)), np.empty(len(triangles)), np.empty(len(triangles))

    def fill(rows: slice) -> None:
        # A block of triangles at a time, one array per coordinate
        # (core.vectors): the numbers of a (T, 3, 3) table of corners
        # without the table (hundreds of MB on a city).
        p = [coordinates(nodes, triangles[rows, k]) for k in range(3)]
        twice_area = cross(minus(p[1], p[0]), minus(p[2], p[0]))
        tri_area[rows] = area = 0.5 * length(twice_area)
        centre = coordinates(reference, tri_owner[rows])
        r = [minus(corner, centre) for corner in p]
        six_v[rows] = dot(r[0], cross(r[1], r[2]))
        nz[rows] = np.divide(twice_area[2], 2 * area, out=np.zeros_like(area), where=area > 0)

    map_blocks(fill, row_blocks(len(triangles), _ROWS))
    roof = nz >= limit
    facade = np.abs(nz) < limit

    def per_block(weights: np.ndarray) -> np.ndarray:
        return np.bincount(tri_owner, weights=weights, minlength=n_blocks + 1)

    return per_block(six_v), per_block(tri_area), per_block(tri_area * roof), per_block(tri_area * facade)


def extreme_per_block(owner: np.ndarray, values: np.ndarray, n_blocks: int, largest: bool,
                      initial: float | None = None) -> np.ndarray:
    """The smallest (or ``largest``) of ``values`` per block ``0..n_blocks``
    (``owner`` of each value), ``initial`` where a block has none (default
    +inf, or -inf for the largest); NaN where a block has a NaN, as
    ``np.minimum.at`` and ``np.maximum.at``, which numpy 1.24 runs at
    40 ns a value (0.16 s on the 1 km city's faces and nodes), where one
    compiled pass (:mod:`core.blocks_kernel`) takes a few ms.

    Examples
    --------
    >>> extreme_per_block(np.array([1, 2, 1]), np.array([0.5, 0.2, 0.3]), 3, largest=False).tolist()
    [inf, 0.3, 0.2, inf]
    """
    if initial is None:
        initial = -np.inf if largest else np.inf
    out = np.full(n_blocks + 1, initial, dtype=np.float64)
    if jit.run("blocks_kernel", "extremes_into", out, owner, values, largest, size=len(values)) is None:
        (np.maximum if largest else np.minimum).at(out, owner, values)
    return out
