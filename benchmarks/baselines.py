"""Side-by-side baselines, on the very points and voxels of a benchmark case.

- voxel binning: the pipeline's ``np.unique`` of voxel numbers, the scatter of
  :meth:`core.grid.VoxelGrid.occupied_cells`, Open3D's
  ``VoxelGrid.create_from_point_cloud`` and, for meshes, trimesh's
  ``mesh.voxelized(pitch)``;
- block labelling (6-connectivity on the building mask):
  :func:`core.blocks.label_blocks`, ``scipy.ndimage.label`` and
  ``skimage.measure.label``;
- a plain numpy copy of arrays of the same sizes: the memory-bandwidth floor.

A baseline whose package is missing is reported as ``"not installed"``.
Every timing is the best of ``repeat`` runs unless the first one takes more
than a few seconds (then once): the figures are floors, not averages.
"""
from __future__ import annotations

import time
from typing import Callable, Iterator

import numpy as np

from core.classify import BUILDING, FACE_ADJACENCY, classify_voxels
from core.clusters import split_clusters
from core.crs import metres_per_unit
from core.grid import GridWindow, VoxelGrid
from core.ground import column_ground_level
from core.manifold import make_well_composed, repair_height_field

NOT_INSTALLED = "not installed"


def best_time(run: Callable[[], object], repeat: int = 3, long: float = 2.0) -> tuple[float, object]:
    """Smallest wall time of ``run()`` over ``repeat`` calls (one call if it takes > ``long`` s)."""
    best, out = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        out = run()
        best = min(best, time.perf_counter() - start)
        if best > long:
            break
    return best, out


def pipeline_grids(ground: np.ndarray, building: np.ndarray, crs, voxel_size: float
                   ) -> Iterator[tuple[VoxelGrid, np.ndarray, np.ndarray]]:
    """The grids :func:`core.pipeline.reconstruct_points` makes, with its local points.

    The same cluster split (data farther apart than 50 m or 20 voxels get grids
    of their own) and the same lattice (one layer under the lowest point, one
    empty layer on top), so the baselines see the pipeline's arrays.
    """
    m = metres_per_unit(crs)
    h = voxel_size / m
    groups = [(ground, building)]
    if len(building):
        gc, bc = split_clusters([ground, building], max(50.0 / m, 20 * h))
        if gc.max() > 0 or bc.max() > 0:
            groups = [(ground[gc == c], building[bc == c]) for c in np.unique(bc) if (gc == c).any()]
    for g, b in groups:
        grid = GridWindow.around(g, b, h).grid(h)
        yield grid, g - grid.offset, b - grid.offset


def front_labels(grid: VoxelGrid, ground: np.ndarray, building: np.ndarray, airborne: bool,
                 max_hole_cells: float) -> np.ndarray:
    """The labels the pipeline's blocks stage first sees (ground/building/air, well composed)."""
    from core.pipeline import _roof_seeds

    level = column_ground_level(grid, ground)
    top_k = repair_height_field(level.top_k)
    cells = grid.occupied_cells(building)
    seeds = None
    if airborne and len(cells):
        seeds = _roof_seeds(grid, cells, top_k, level.observed, max_hole_cells)
    labels = classify_voxels(grid, top_k, cells, seeds, fill_to_top=airborne)
    make_well_composed(labels)
    return labels


def unique_cells(grid: VoxelGrid, points: np.ndarray) -> np.ndarray:
    """The reference binning: distinct voxel numbers (paper eq. 1) by a sort."""
    nx, ny, _ = grid.shape
    number = np.unique(grid.voxel_number(grid.cell_of(points)))
    return np.column_stack([number % nx, (number // nx) % ny, number // (nx * ny)])


def binning(grids: list[tuple[VoxelGrid, np.ndarray, np.ndarray]], repeat: int = 3) -> dict:
    """Building-point binning by np.unique (the reference), by scatter (the pipeline's), and by Open3D."""
    n = sum(len(b) for _, _, b in grids)
    out: dict = {"points": int(n), "unique_s": 0.0, "fast_s": 0.0, "fast_shuffled_s": 0.0,
                 "cells": 0, "equal": True}
    rng = np.random.default_rng(0)
    for grid, _, b in grids:
        t_ref, ref = best_time(lambda: unique_cells(grid, b), repeat)
        t_fast, fast = best_time(lambda: grid.occupied_cells(b), repeat)
        shuffled = b[rng.permutation(len(b))]
        t_shuf, _ = best_time(lambda: grid.occupied_cells(shuffled), repeat)
        del shuffled
        out["unique_s"] += t_ref
        out["fast_s"] += t_fast
        out["fast_shuffled_s"] += t_shuf
        out["cells"] += int(len(ref))
        out["equal"] = bool(out["equal"] and np.array_equal(ref, fast))
    try:
        import open3d as o3d
    except ImportError:
        out["open3d_s"] = NOT_INSTALLED
    else:
        out["open3d_convert_s"], out["open3d_s"] = 0.0, 0.0
        for grid, _, b in grids:
            start = time.perf_counter()
            cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.ascontiguousarray(b)))
            out["open3d_convert_s"] += time.perf_counter() - start
            t, voxels = best_time(lambda: o3d.geometry.VoxelGrid.create_from_point_cloud(
                cloud, voxel_size=grid.voxel_size), repeat)
            out["open3d_s"] += t
            out.setdefault("open3d_cells", 0)
            out["open3d_cells"] += len(voxels.get_voxels())
            del cloud, voxels
    return out


def trimesh_voxelise(path: str, pitch: float) -> dict:
    """trimesh's ``mesh.voxelized(pitch)`` (subdivide triangles, bin vertices) of a mesh file."""
    try:
        import trimesh
    except ImportError:
        return {"trimesh_s": NOT_INSTALLED}
    mesh = trimesh.load(path, force="mesh")
    start = time.perf_counter()
    voxels = mesh.voxelized(pitch)
    seconds = time.perf_counter() - start
    return {"trimesh_s": seconds, "trimesh_cells": int(voxels.filled_count), "triangles": int(len(mesh.faces))}


def labelling(labels_per_grid: Iterator[np.ndarray], repeat: int = 2) -> dict:
    """6-connected labelling of the building mask: ours, scipy.ndimage, skimage.measure."""
    from scipy import ndimage

    from core.blocks import label_blocks

    try:
        from skimage.measure import label as sk_label
    except ImportError:
        sk_label = None
    out: dict = {"voxels": 0, "ours_s": 0.0, "scipy_s": 0.0, "mask_s": 0.0,
                 "skimage_s": 0.0 if sk_label else NOT_INSTALLED, "components": 0, "equal": True}
    for labels in labels_per_grid:
        out["voxels"] += int(labels.size)
        t, (_, n) = best_time(lambda: label_blocks(labels), repeat)
        out["ours_s"] += t
        out["components"] += n
        t, mask = best_time(lambda: labels == BUILDING, repeat)
        out["mask_s"] += t
        t, (_, n_scipy) = best_time(lambda: ndimage.label(mask, structure=FACE_ADJACENCY), repeat)
        out["scipy_s"] += t
        if sk_label is not None:
            t, (_, n_sk) = best_time(lambda: sk_label(mask, connectivity=1, return_num=True), repeat)
            out["skimage_s"] += t
            out["equal"] = bool(out["equal"] and n_sk == n)
        out["equal"] = bool(out["equal"] and n_scipy == n)
        del mask, labels
    return out


def copy_floor(sizes: dict[str, int], repeat: int = 3) -> dict:
    """GB/s of ``np.copyto`` between two pre-touched arrays of each size (bytes copied / s)."""
    out = {}
    for name, nbytes in sizes.items():
        if nbytes <= 0:
            continue
        src = np.ones(nbytes, np.uint8)
        dst = np.zeros(nbytes, np.uint8)
        dst[::4096] = 1  # touch every page: page faults are not bandwidth
        t, _ = best_time(lambda: np.copyto(dst, src), repeat)
        out[name] = {"bytes": int(nbytes), "seconds": t, "gb_per_s": nbytes / t / 1e9}
        del src, dst
    return out
