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
from .grid import VoxelGrid
from .measure import BlockMeasures
from .reconstruction import Reconstruction
from .surface import SurfaceModel


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
    # The cells' two indices as separate arrays: numpy's reductions along
    # axis 0 of (N, 2) tables stride through them.
    cells = [[np.floor(points[:, k] / gap).astype(np.int64) for k in range(2)] for points in parts]
    present = [c for c, points in zip(cells, parts) if len(points)]
    lower = [min(c[k].min() for c in present) for k in range(2)]
    for c in cells:
        c[0] -= lower[0]
        c[1] -= lower[1]
    shape = tuple(max(c[k].max() for c in present) + 1 for k in range(2))
    occupied = np.zeros(shape, dtype=bool)
    for i, j in cells:
        occupied[i, j] = True
    labels, n = ndimage.label(occupied, structure=np.ones((3, 3), bool))
    if n <= 1:
        return [np.zeros(len(i), dtype=labels.dtype) for i, _ in cells]
    return [labels[i, j] - 1 for i, j in cells]


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
    warnings.append(f"The data fall into {len(parts)} separate clusters, each reconstructed on its own "
                    "grid; every cluster has its own ground and air volumes.")
    return Reconstruction(crs=parts[0].crs, grid=grid, blocks=table, surface=surface, mesh=mesh,
                          measures=measure, footprint_columns=np.concatenate(columns),
                          warnings=warnings, timings=timings,
                          stats={"clusters": len(parts)})
