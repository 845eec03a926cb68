"""Scattered data: one voxel grid per cluster of buildings, merged after.

A city model often holds buildings kilometres apart (a CityGML export of
selected buildings, LoD2 tiles with gaps). One grid around all of them would
be mostly empty and too large for memory, so data whose occupied area falls
into groups separated by more than ``gap`` are reconstructed group by group,
on the same global lattice, and the results are merged: blocks are
renumbered, and the ground and air of every group keep the region ids
``GROUND_REGION`` and ``AIR_REGION`` (each group's ground and air are closed
volumes of their own, disjoint from the others').

A point cloud with ground points everywhere forms a single cluster.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from .blocks import BlockTable
from .errors import UrbanvoxError
from .grid import VoxelGrid, bounds
from .measure import BlockMeasures
from .parallel import map_blocks, row_blocks
from .progress import Text
from .reconstruction import Reconstruction
from .surface import SurfaceModel

#: Points per block of :func:`split_clusters`: a few MB of temporaries, and blocks long
#: enough that the two threads do not wait on each other for the GIL (1 << 16: 1.05 s, 0.9 s so).
_ROWS = 1 << 18
#: Cells of the largest grid of :func:`split_clusters` made whole (4 MB of flags, 200 km square
#: in 50 m cells); data spread wider (a stray point thousands of km away, files of far apart
#: places) are clustered through their occupied cells only.
DENSE_CELLS = 1 << 22
#: Cells of a row in the keys of :func:`_split_sparse`: any grid of 50 m cells on Earth is narrower.
_KEY_ROW = 1 << 31


def split_clusters(parts: Sequence[np.ndarray], gap: float) -> list[np.ndarray]:
    """Cluster index of every point of each array: groups of ``gap``-sized
    cells touching (8-neighbours), over the points of all the arrays.

    The arrays (ground and building points) are not concatenated: a copy of
    a city's points is hundreds of MB. A single cluster, the usual case,
    gives arrays of zeros without looking the points up again.

    Examples
    --------
    >>> pts = np.array([[0, 0, 0], [10, 0, 0], [500, 0, 0]], float)
    >>> [c.tolist() for c in split_clusters([pts[:2], pts[2:]], 50.0)]
    [[0, 0], [1]]
    """
    present = [points for points in parts if len(points)]
    if not present:
        return [np.zeros(0, dtype=np.int32) for _ in parts]
    # The cells of the lowest and highest coordinates bound every point's
    # (floor and the division are monotone).
    lowest, highest = bounds(present)
    span = float(np.max(highest[:2] - lowest[:2]))
    if not span / gap < _KEY_ROW - 2:  # NaN too; a cell and its neighbours keep keys of their own
        raise UrbanvoxError(f"The data span {span:.4g} units across: far more than any city. A point far away "
                            "(a corrupt coordinate or scale in a file) or files of different coordinate "
                            "systems? Crop the data (EXTENT) or fix the file.")
    lower = np.floor(lowest[:2] / gap).astype(np.int64)
    shape = tuple(int(v) for v in np.floor(highest[:2] / gap).astype(np.int64) - lower + 1)

    def cells(points: np.ndarray, rows: slice) -> tuple[np.ndarray, np.ndarray]:
        return tuple(np.floor(points[rows, k] / gap).astype(np.int64) - lower[k] for k in range(2))

    def occupied_by(points: np.ndarray, rows: slice) -> np.ndarray:
        mask = np.zeros(shape, dtype=bool)
        mask[cells(points, rows)] = True
        return mask

    if shape[0] * shape[1] > DENSE_CELLS:
        return _split_sparse(parts, cells)
    # Blocks of points on all cores, each marking a grid of its own (a few
    # kB): no table of every point's cells, 4 arrays of 8 bytes a point (the
    # 2 km city's 50 M points: 2.8-3.4 s -> 0.9 s, most of it fresh pages).
    occupied = np.zeros(shape, dtype=bool)
    for points in present:
        for mask in map_blocks(lambda rows, points=points: occupied_by(points, rows),
                               row_blocks(len(points), _ROWS)):
            occupied |= mask
    labels, n = ndimage.label(occupied, structure=np.ones((3, 3), bool))
    if n <= 1:
        return [np.zeros(len(points), dtype=labels.dtype) for points in parts]
    out = [np.empty(len(points), dtype=labels.dtype) for points in parts]
    for points, cluster in zip(parts, out):
        def fill(rows: slice, points: np.ndarray = points, cluster: np.ndarray = cluster) -> None:
            cluster[rows] = labels[cells(points, rows)] - 1

        map_blocks(fill, row_blocks(len(points), _ROWS))
    return out


def _split_sparse(parts: Sequence[np.ndarray], cells) -> list[np.ndarray]:
    """:func:`split_clusters` through the occupied cells only (``cells(points,
    rows)``: their indices): the same clusters, numbered alike (by their first
    cell in the order of the rows of a whole grid, as ``ndimage.label``)."""
    def keys(points: np.ndarray, rows: slice) -> np.ndarray:
        i, j = cells(points, rows)
        return np.unique(i * _KEY_ROW + j)

    occupied = np.unique(np.concatenate([np.zeros(0, np.int64)] + [
        key for points in parts if len(points) for key in map_blocks(
            lambda rows, points=points: keys(points, rows), row_blocks(len(points), _ROWS))]))
    # Each occupied cell with its occupied 8-neighbours ahead of it in row order.
    i, j = np.divmod(occupied, _KEY_ROW)
    first, second = [], []
    for di, dj in ((0, 1), (1, -1), (1, 0), (1, 1)):
        key = (i + di) * _KEY_ROW + (j + dj)
        at = np.minimum(np.searchsorted(occupied, key), len(occupied) - 1)
        found = (occupied[at] == key) & (j + dj >= 0)
        first.append(np.flatnonzero(found))
        second.append(at[found])
    first, second = np.concatenate(first), np.concatenate(second)
    graph = coo_matrix((np.ones(len(first), np.int8), (first, second)), shape=(len(occupied),) * 2)
    n, component = connected_components(graph, directed=False)
    # Components numbered by their first cell in row order, as ndimage.label numbers them.
    first_cell = np.full(n, len(occupied))
    np.minimum.at(first_cell, component, np.arange(len(occupied)))
    rank = np.empty(n, np.int32)
    rank[np.argsort(first_cell)] = np.arange(n, dtype=np.int32)
    label = rank[component]
    out = [np.empty(len(points), dtype=np.int32) for points in parts]
    for points, cluster in zip(parts, out):
        def fill(rows: slice, points: np.ndarray = points, cluster: np.ndarray = cluster) -> None:
            i, j = cells(points, rows)
            cluster[rows] = label[np.searchsorted(occupied, i * _KEY_ROW + j)]

        map_blocks(fill, row_blocks(len(points), _ROWS))
    return out


def merge(parts: list[Reconstruction]) -> Reconstruction:
    """One reconstruction from the reconstructions of separate clusters."""
    h = parts[0].grid.voxel_size
    offset = np.min([p.grid.offset for p in parts], axis=0)
    nodes, quads, regions, moved, columns = [], [], [], [], []
    tables, measures, warnings = [], [], []
    n_nodes = 0
    n_blocks = 0
    for part in parts:
        shift = part.grid.offset - offset  # a whole number of voxels: one global lattice
        renumber = np.concatenate([[0], np.arange(1, len(part.blocks) + 1) + n_blocks])
        region = part.surface.regions.copy()
        positive = region > 0
        region[positive] = renumber[region[positive]]
        nodes.append(part.surface.nodes + shift)
        moved.append(part.mesh.nodes + shift)
        quads.append(part.surface.quads + n_nodes)
        regions.append(region)
        t = part.blocks
        tables.append(BlockTable(block_id=t.block_id + n_blocks, n_voxels=t.n_voxels, volume=t.volume,
                                 footprint_area=t.footprint_area, ground_z=t.ground_z + shift[2],
                                 top_z=t.top_z + shift[2]))
        measures.append(part.measures)
        cells = np.rint(shift[:2] / h).astype(np.int64)
        fc = part.footprint_columns.copy()
        fc[:, 0] += n_blocks
        fc[:, 1:] += cells
        columns.append(fc)
        warnings.extend(w for w in part.warnings if w not in warnings)
        n_nodes += len(part.surface.nodes)
        n_blocks += len(part.blocks)
    surface = SurfaceModel(np.concatenate(nodes), np.concatenate(quads), np.concatenate(regions))
    mesh = SurfaceModel(np.concatenate(moved), surface.quads, surface.regions)
    table = BlockTable.concatenate(tables)
    measure = BlockMeasures.concatenate(measures)
    upper = np.max([p.grid.offset + np.asarray(p.grid.shape) * h for p in parts], axis=0)
    grid = VoxelGrid(offset, np.zeros(3), h, tuple(int(n) for n in np.rint((upper - offset) / h)))
    timings: dict[str, float] = {}
    for part in parts:
        for stage, seconds in part.timings.items():
            timings[stage] = timings.get(stage, 0.0) + seconds
    if len(parts) > 1:  # one part: the others were ground alone, far from any building, left out
        warnings.append(Text("The data fall into {} separate clusters, each reconstructed on its own grid; every "
                             "cluster has its own ground and air volumes.", len(parts)))
    return Reconstruction(crs=parts[0].crs, grid=grid, blocks=table, surface=surface, mesh=mesh,
                          measures=measure, footprint_columns=np.concatenate(columns),
                          warnings=warnings, timings=timings,
                          stats={"clusters": len(parts)})
