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

from .blocks import BlockTable
from .grid import VoxelGrid, bounds
from .measure import BlockMeasures
from .parallel import map_blocks, row_blocks
from .progress import Text
from .reconstruction import Reconstruction
from .surface import SurfaceModel

#: Points per block of :func:`split_clusters`: a few MB of temporaries, and blocks long
#: enough that the two threads do not wait on each other for the GIL (1 << 16: 1.05 s, 0.9 s so).
_ROWS = 1 << 18


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
    lower = np.floor(lowest[:2] / gap).astype(np.int64)
    shape = tuple(int(v) for v in np.floor(highest[:2] / gap).astype(np.int64) - lower + 1)

    def cells(points: np.ndarray, rows: slice) -> tuple[np.ndarray, np.ndarray]:
        return tuple(np.floor(points[rows, k] / gap).astype(np.int64) - lower[k] for k in range(2))

    def occupied_by(points: np.ndarray, rows: slice) -> np.ndarray:
        mask = np.zeros(shape, dtype=bool)
        mask[cells(points, rows)] = True
        return mask

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
    warnings.append(Text("The data fall into {} separate clusters, each reconstructed on its own grid; every "
                         "cluster has its own ground and air volumes.", len(parts)))
    return Reconstruction(crs=parts[0].crs, grid=grid, blocks=table, surface=surface, mesh=mesh,
                          measures=measure, footprint_columns=np.concatenate(columns),
                          warnings=warnings, timings=timings,
                          stats={"clusters": len(parts)})
