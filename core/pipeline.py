"""The method end to end: data in, voxel model, blocks and surfaces out.

:func:`reconstruct_point_cloud` and :func:`reconstruct_mesh` read their
input into ground points and building points (world coordinates), and
:func:`reconstruct_points` runs the paper's steps on them in order:

=======================================  ==========================  ======
step                                     module                      paper
=======================================  ==========================  ======
parameters and points, checked           :mod:`core.inputs`
lattice around the data                  :mod:`core.grid`            §2
ground level of every column             :mod:`core.ground`          §2
ground / building / air                  :mod:`core.classify`        §2
well-composed labels                     :mod:`core.manifold`        §3.3
blocks and thresholds                    :mod:`core.blocks`          §3.1-2
unsupported boundary voxels              :mod:`core.eliminate`       §3.4
conforming surfaces                      :mod:`core.surface`         §3.3
constrained smoothing                    :mod:`core.smooth`          §4.1
normals and projection on the data       :mod:`core.project`         §4.2
per-block mesh measures                  :mod:`core.measure`
=======================================  ==========================  ======

Every function takes ``progress(fraction, message)`` and ``is_cancelled()``
callables (:mod:`core.progress`: a message made of parts keeps them, for
QGIS to translate); a cancelled run raises :class:`~core.errors.Cancelled`
before anything is written.
"""
from __future__ import annotations

import os
import time
from dataclasses import replace
from pathlib import Path
from typing import Sequence

import numpy as np

from . import jit
from .block_buildings import block_buildings
from .blocks import block_columns, blocks_above_thresholds
from .classify import classify_voxels, hollow_share, roof_hole_columns
from .clusters import merge as merge_clusters
from .clusters import split_clusters
from .crs import metres_per_unit, resolve_crs
from .eliminate import eliminate_unsupported
from .errors import Cancelled, UrbanvoxError
from .grid import GridWindow, sparse_points_warning
from .ground import GroundLevel, NearGround, column_ground_level
from .heap import THREAD_HEAP_FRESH, fault_in_ahead, reusing_freed_memory, use_array_heap_here
from .inputs import ReconstructionParams, checked_points
from .memory import available_memory, check_face_memory, check_memory, voxel_bytes
from .manifold import make_well_composed, repair_height_field
from .measure import block_face_split, extreme_per_block, measure_blocks
from .neighbours import nearest_distance, point_index, search_of_first
from .parallel import in_background
from .progress import CancelCheck, Progress, Text, part, part_with_message
from .project import COLUMN_VOXELS, project_nodes
from .reconstruction import NO_BLOCK, Reconstruction
from .sampling import check_sample_memory
from .smooth import NodeRoles, smooth
from .surface import SurfaceModel, region_volume
from .tiles import TileOptions, reconstruct_tiled
from .topology import surface_area

#: Above this share of hollow building columns (air under a roof), a mesh's
#: surfaces are taken for open (core.classify.hollow_share): closed models
#: measured 0-5 % (passages, overhangs), the Rotterdam CityJSON, whose row
#: houses lack their party walls, 78 %.
HOLLOW_WARNING = 0.25

#: Where each step of :func:`reconstruct_points` starts on the progress bar:
#: the steps' shares of its time on the 1 km synthetic city at 1 m (12.5 M
#: points: grid 0.44 s, ground 0.49, classes 0.62, blocks 0.17, elimination
#: 0.99, surfaces 0.82, smoothing 2.05, the blocks' projection 4.89, the
#: ground's 2.5, measures 1.59; Delft at 0.5 m is alike). The fractions
#: before (0.2, 0.3, ... 0.85) left the bar at 85 % for the last 61 % of
#: the run (10.9 of 17.8 s).
STEP_STARTS = {"ground": 0.03, "classify": 0.06, "blocks": 0.11, "eliminate": 0.12, "surface": 0.19,
               "smooth": 0.24, "project_blocks": 0.38, "project_ground": 0.72, "measure": 0.89}

#: The share of the progress bar for reading a point cloud (the 1 km city:
#: 2.3 s of reading before 14.6 s of method; Delft 0.07 s before 0.8 s), and
#: for reading and sampling a mesh (Zurich's at 1 m: 0.3 s and 1.0-1.7 s
#: before 2.3 s).
READ_SHARE = 0.13
MESH_READ_SHARE, MESH_SAMPLE_SHARE = 0.07, 0.35


@reusing_freed_memory()
def reconstruct_point_cloud(paths: str | Path | Sequence[str | Path], *, crs: str | None = None,
                            ground_classes: str | Sequence[int] = "2",
                            building_classes: str | Sequence[int] = "6",
                            params: ReconstructionParams | None = None,
                            tiles: TileOptions | None = None,
                            progress: Progress | None = None,
                            is_cancelled: CancelCheck | None = None) -> Reconstruction:
    """Voxel model from one or several LAS/LAZ files with ground classification.

    Parameters
    ----------
    paths : path or sequence of paths
        LAS/LAZ files (a tile collection is read as one cloud).
    crs : str, optional
        CRS of the data; required when the file header has none.
    ground_classes, building_classes : str or sequence of int
        Class codes of the ground and of the buildings ("2", "6" in ASPRS);
        other classes (vegetation, noise, ...) are ignored.
    tiles : TileOptions, optional
        Reconstruct tile by tile, here or on Dask workers (:mod:`core.tiles`).
    """
    from .readers.las import parse_classes, read_point_clouds

    params = params or ReconstructionParams()
    report = _reporter(progress, is_cancelled)
    report(0.0, "Reading point cloud")
    if isinstance(paths, (str, Path)):
        paths = [paths]
    points = read_point_clouds([str(p) for p in paths], parse_classes(ground_classes),
                               parse_classes(building_classes), crs, is_cancelled,
                               progress=part(progress, 0.0, READ_SHARE))
    return reconstruct_points(points.ground, points.building, points.crs, params,
                              airborne=True, warnings=list(points.warnings), tiles=tiles,
                              progress=part(progress, READ_SHARE, 1.0), is_cancelled=is_cancelled,
                              overwrite_points=True)


@reusing_freed_memory()
def reconstruct_mesh(path: str | Path, *, crs: str | None = None, ground_path: str | Path | None = None,
                     params: ReconstructionParams | None = None, fill_under_roofs: bool = False,
                     lod: str | None = None,
                     tiles: TileOptions | None = None,
                     progress: Progress | None = None,
                     is_cancelled: CancelCheck | None = None) -> Reconstruction:
    """Voxel model from a building mesh (STL/OBJ/PLY/OFF) of any quality, or
    from a CityJSON city model.

    Triangles are sampled so neighbouring points are at most 10 % of a voxel
    apart (paper §2). The ground is ``ground_path`` (a mesh, or a CityJSON
    file's terrain) if given, else a CityJSON file's own terrain if it has
    one, else it passes through the bottom of every building part
    (:func:`core.readers.mesh.base_points`). ``crs`` is needed unless the
    file names one (CityJSON's ``referenceSystem``; a mesh never does).

    ``lod`` picks a CityJSON file's level of detail where an object has it
    (:func:`core.readers.cityjson.read_cityjson`); the others give their
    highest.

    ``fill_under_roofs`` makes every column solid from the ground up to its
    highest building point, as for airborne LiDAR: for models whose walls are
    missing (the air would fill them, with a warning), at the price of
    passages and overhangs. Unlike LiDAR, no roof hole is filled: a mesh has
    no missing returns, and a courtyard is air.

    A CityJSON file's buildings are named per block in the result's
    ``block_buildings`` (:func:`name_buildings`).
    """
    params = params or ReconstructionParams()
    report = _reporter(progress, is_cancelled)
    report(0.0, "Reading mesh")
    crs_obj, triangles, ground_triangles, warnings = read_surfaces(path, crs, ground_path, lod, is_cancelled)
    unit = metres_per_unit(crs_obj)
    report(MESH_READ_SHARE, "Sampling triangles")
    ground, building = sample_surfaces(triangles, ground_triangles, params.voxel_size / unit, unit, is_cancelled,
                                       part(report, MESH_READ_SHARE, MESH_SAMPLE_SHARE), params.max_memory)
    if fill_under_roofs:
        params = replace(params, max_roof_hole_area=0.0)
    result = reconstruct_points(ground, building, crs_obj, params, airborne=fill_under_roofs, warnings=warnings,
                                tiles=tiles, progress=part(progress, MESH_SAMPLE_SHARE, 1.0),
                                is_cancelled=is_cancelled, overwrite_points=True)
    name_buildings(result, triangles)
    return result


def name_buildings(result: Reconstruction, triangles) -> None:
    """Where ``triangles`` (the input's) name their buildings, as a city
    model's do: set which block holds which (:mod:`core.block_buildings`) on
    ``result``, and warn of the buildings in none."""
    if triangles.owner is None:
        return
    corner = result.grid.offset[:2] + result.grid.origin[:2]
    result.block_buildings, in_none = block_buildings(triangles, result.footprint_columns,
                                                      np.asarray(result.blocks.block_id), corner,
                                                      result.grid.voxel_size)
    if in_none:
        result.warnings.append(Text("{} of the city model's {} buildings are in no block (below the "
                                    "thresholds, outside the extent, or less than a quarter of their plan "
                                    "area in any one block).", in_none, len(triangles.owner_ids)))


def read_surfaces(path: str | Path, crs: str | None = None, ground_path: str | Path | None = None,
                  lod: str | None = None, is_cancelled: CancelCheck | None = None):
    """The input of :func:`reconstruct_mesh`: its CRS (pyproj), the buildings'
    triangles, the ground's (None: none given, the buildings' bottoms serve)
    and the reading's warnings. The benchmarks time it apart."""
    from .readers.cityjson import is_cityjson, read_cityjson
    from .readers.mesh import read_triangles

    if is_cityjson(path):
        city = read_cityjson(path, is_cancelled, lod)
        crs_obj = resolve_crs(city.crs, crs, str(path))
        if city.buildings is None:
            raise UrbanvoxError(f"{path} has terrain but no building surfaces (Building, BuildingPart or "
                                "BuildingInstallation objects); give it as the ground mesh instead.")
        triangles, ground_triangles, warnings = city.buildings, city.terrain, list(city.warnings)
    else:
        if not crs or not str(crs).strip():  # before a long read
            raise UrbanvoxError(f"{os.path.basename(str(path))} is a mesh, which carries no CRS: set the CRS "
                                "parameter (e.g. EPSG:2056).")
        crs_obj = resolve_crs(None, crs, str(path))
        triangles = read_triangles(str(path), is_cancelled)
        ground_triangles, warnings = None, list(triangles.warnings)
        if lod:
            warnings.append(f"A level of detail ({lod}) is for CityJSON input; {os.path.basename(str(path))} "
                            "is a mesh, read whole.")
    if ground_path:
        ground_triangles = _ground_triangles(ground_path, is_cancelled)
    return crs_obj, triangles, ground_triangles, warnings


def sample_surfaces(triangles, ground_triangles, h: float, unit: float,
                    is_cancelled: CancelCheck | None = None,
                    progress: Progress | None = None,
                    max_memory: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Ground and building points of :func:`read_surfaces`' triangles, for voxels
    of ``h`` CRS units (``unit`` metres each); ``progress`` goes over the
    samples made. Refused before sampling if their points would need more
    than ``max_memory`` bytes (default: the memory available,
    :func:`core.sampling.check_sample_memory`)."""
    from .readers.mesh import base_points
    from .sampling import estimate_sample_count, sample_thinned

    area = sum(surface_area(mesh.vertices, mesh.faces) for mesh in (triangles, ground_triangles) if mesh is not None)
    check_sample_memory(area, h / 3, h * unit, max_memory or available_memory(), unit)

    # Samples at 10 % of a voxel (paper §2), kept as one mean point per third
    # of a voxel: the same voxel occupancy, a tenth of the points.
    # The buildings' share of the bar: their share of the samples; without a
    # ground mesh, three quarters (the base points took a quarter of Zurich's
    # sampling at 1 m: 0.26-0.39 s of 1.3-2.1 s).
    middle = 0.75
    if ground_triangles is not None:
        counts = [estimate_sample_count(mesh.corners(), 0.1 * h) for mesh in (triangles, ground_triangles)]
        middle = counts[0] / max(sum(counts), 1)
    building = sample_thinned(triangles.corners(), 0.1 * h, h / 3, is_cancelled,
                              progress=part(progress, 0.0, middle))
    if ground_triangles is not None:
        ground = sample_thinned(ground_triangles.corners(), 0.1 * h, h / 3, is_cancelled,
                                progress=part(progress, middle, 1.0))
    else:
        ground = base_points(triangles, h, unit=unit)
    return ground, building


def _ground_triangles(path: str | Path, is_cancelled: CancelCheck | None):
    """The triangles of a ground mesh, or a CityJSON file's terrain."""
    from .readers.cityjson import is_cityjson, read_cityjson
    from .readers.mesh import read_triangles

    if not is_cityjson(path):
        return read_triangles(str(path), is_cancelled)
    terrain = read_cityjson(path, is_cancelled).terrain
    if terrain is None:
        raise UrbanvoxError(f"The ground file {path} has no terrain (TINRelief objects with surfaces).")
    return terrain


@reusing_freed_memory()
def reconstruct_points(ground: np.ndarray, building: np.ndarray, crs, params: ReconstructionParams,
                       *, airborne: bool, warnings: list[str] | None = None,
                       progress: Progress | None = None,
                       is_cancelled: CancelCheck | None = None,
                       split: bool = True, tiles: TileOptions | None = None,
                       window: GridWindow | None = None,
                       ground_level: GroundLevel | None = None,
                       overwrite_points: bool = False) -> Reconstruction:
    """The paper's §2-4 on ground and building points in world coordinates.

    Parameters
    ----------
    ground, building : ndarray of shape (G, 3), (B, 3)
        World coordinates.
    crs : pyproj.CRS
        Projected CRS of the coordinates.
    params : ReconstructionParams
    airborne : bool
        Point cloud seen from above: every column is solid from the ground up
        to its highest building point, roof holes are filled, and walls are
        supported by the roof edge above them (:mod:`core.classify`,
        :mod:`core.eliminate`).
    split : bool
        Without an extent, reconstruct clusters of data farther apart than
        50 m (or 20 voxels) on grids of their own (:mod:`core.clusters`).
    tiles : TileOptions, optional
        Cut the domain into tiles reconstructed separately, possibly on Dask
        workers, and merge them (:mod:`core.tiles`). Blocks come out as a
        single run makes them.
    window : GridWindow, optional
        Internal (:mod:`core.tiles`): the exact grid, a window of a larger
        lattice; the points are already cropped to it.
    ground_level : GroundLevel, optional
        Internal (:mod:`core.tiles`): the ground of the window's columns,
        taken from the whole domain's.
    overwrite_points : bool
        The run may change ``ground`` and ``building``: they are moved to
        the grid's frame in place, not copied (a copy of every point, 300 MB
        on a 1 km² city, would stay beside the caller's all run long).
    """
    report = _reporter(progress, is_cancelled)
    warnings = list(warnings or [])
    timings: dict[str, float] = {}
    peak_rss: dict[str, float] = {}
    clock = time.perf_counter()

    def lap(name: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        timings[name] = now - clock
        peak_rss[name] = _peak_rss_mb()
        clock = now

    m = metres_per_unit(crs)
    h = params.voxel_size / m
    if not np.isfinite(h) or h <= 0:
        raise UrbanvoxError(f"The voxel size must be a positive number (got {params.voxel_size}).")
    ground, building = checked_points(ground, building, params.extent, airborne, warnings)
    if split and params.extent is None and len(building):
        ground_cluster, building_cluster = split_clusters([ground, building], max(50.0 / m, 20 * h))
        if ground_cluster.max() > 0 or building_cluster.max() > 0:
            return _reconstruct_clusters(ground, building, ground_cluster, building_cluster, crs, params,
                                         airborne, warnings, progress, is_cancelled, tiles)
        del ground_cluster, building_cluster  # a number per point: 200 MB on the 2 km city, for the whole run
    if window is None:
        window = GridWindow.around(ground, building, h, params.extent)
        if tiles is not None and tiles.cuts(window, params.voxel_size):
            return reconstruct_tiled(ground, building, crs, params, airborne, window, tiles,
                                     warnings, progress, is_cancelled)

    grid = window.grid(h)
    needed = check_memory(grid.shape, params.voxel_size, params.max_memory, voxel_bytes(grid.n_voxels), tile_hint=True,
                          points=len(ground) + len(building))
    if needed >= THREAD_HEAP_FRESH:
        # In a host's thread (QGIS), arrays this large from the array heap
        # (a large point cloud's reader asked already; a mesh's run asks here).
        use_array_heap_here(load=True)
    # That memory's pages, where the heap does not hold them yet (a process's
    # first run), are faulted in meanwhile on a core the run leaves idle. At
    # most half the memory the run may use: the estimate is the guard's, on the
    # safe side, and the pages are the process's until the heap is handed back.
    fault_in_ahead(min(needed, (params.max_memory or available_memory()) // 2))
    # Many points (not read from a file, which preloads them itself): the
    # kernels load meanwhile. Not for many voxels alone: Delft at 0.5 m (3.8 M
    # voxels, 120 k points) took 1.25-1.32 s in a first run with them all
    # loading beside the ground and classes, 1.23-1.27 s with each loaded at
    # its first call (ten runs each, in turn, in two sets): the loading holds
    # the GIL, and a preload also loads the kernels a run does not use.
    jit.preload(len(ground) + len(building))
    lower = grid.offset
    if overwrite_points:
        ground -= lower
        building -= lower
    else:
        ground = ground - lower
        building = building - lower
    # The searches over the points (one over the building points serves the
    # elimination, the projection and the distances measured at the end; one
    # over the ground points those distances) are built on a thread of their
    # own, the buildings' while the voxel steps run, which mostly use one
    # core: 1.4 s of KD-tree builds on the 1 km city. They hold these arrays,
    # not copies of them: nothing below writes to them. With numba both get a
    # compiled index of columns instead of a KD-tree (neighbours.point_index),
    # faster to build and to search. The ground's long searches (walls far
    # from any ground point) are few since NearGround skips the nodes high
    # above it, and each goes no farther than the node's distance to the
    # building points: on the 1 km city they take 0.11 s against the
    # KD-tree's 0.5 s, and the index 0.18 s (both cores) against 0.65-0.77 s.
    building_search = in_background(point_index, building, COLUMN_VOXELS * h)
    near_ground = in_background(NearGround, grid, ground)
    lap("grid")

    report(STEP_STARTS["ground"], "Ground level of every column")
    level = ground_level if ground_level is not None else column_ground_level(grid, ground)
    top_k = repair_height_field(level.top_k)
    building_cells = grid.occupied_cells(building)
    if airborne and len(building_cells):
        sparse = sparse_points_warning(len(building), building_cells, params.voxel_size)
        if sparse:
            warnings.append(sparse)
    lap("ground")

    classifying = part_with_message(report, STEP_STARTS["classify"], STEP_STARTS["blocks"],
                                    "Sorting voxels into ground, building and air")
    classifying(0.0)
    seeds = None
    if airborne and len(building_cells):
        seeds = _roof_seeds(grid, building_cells, top_k, level.observed,
                            params.max_roof_hole_area / m**2)
        if len(seeds):
            warnings.append(Text("Filled {} roof-hole columns ({:.0f} m²) with no return under them.",
                                 len(seeds), len(seeds) * (h * m) ** 2))
        # The roof holes take 0.2 of the step, the labels 0.35, their repair the
        # rest (the 1 km city at 0.5 m: 0.6, 0.9 and 1.45 s).
        classifying(0.2)
    labels = classify_voxels(grid, top_k, building_cells, seeds, fill_to_top=airborne,
                             is_cancelled=is_cancelled)
    classifying(0.55)
    make_well_composed(labels, is_cancelled=is_cancelled)
    if not airborne:
        # Said without the share, so that clusters and tiles say it once (their warnings are merged).
        if hollow_share(labels) > HOLLOW_WARNING:
            warnings.append(Text("Over {:.0%} of the building columns have air under a roof: the surfaces are "
                                 "probably not closed (missing walls let the air in) and the blocks are hollow. "
                                 "FILL_UNDER_ROOFS (--fill-under-roofs) fills every column up to its roof.",
                                 HOLLOW_WARNING))
    lap("classify")

    report(STEP_STARTS["blocks"], "Building blocks")
    thresholds = (params.min_height / m, params.min_footprint / m**2, params.min_volume / m**3)
    # Only the labels, the small blocks dropped, go on: the blocks are
    # labelled again after the elimination. Their volume (int32, 2.7 GB on
    # the 1 km city at 0.5 m) is freed first, for that labelling to reuse.
    dropped = blocks_above_thresholds(labels, grid, *thresholds)[2]
    lap("blocks")

    eliminating = part_with_message(report, STEP_STARTS["eliminate"], STEP_STARTS["surface"],
                                    "Eliminating unsupported boundary voxels")
    eliminating(0.0)
    building_search = building_search.result()
    # Dropping whole blocks left the labels well-composed (core.blocks.drop_blocks):
    # only the cubes around the voxels eliminated need the repair. The passes
    # take 0.7 of the step, the repair and the blocks again 0.15 each (the 1 km city).
    eliminated = eliminate_unsupported(labels, grid, building, params.support, extrude_roofs=airborne,
                                       is_cancelled=is_cancelled, search=building_search,
                                       progress=lambda share: eliminating(0.7 * share))
    make_well_composed(labels, is_cancelled=is_cancelled, changed=eliminated)
    eliminating(0.85)  # and a cancel check
    blocks, table, dropped_after = blocks_above_thresholds(labels, grid, *thresholds)
    lap("eliminate")
    if dropped or dropped_after:
        warnings.append(Text("Dropped {} blocks below the thresholds (height {:g} m, footprint {:g} m², "
                             "volume {:g} m³).", dropped + dropped_after, params.min_height, params.min_footprint,
                             params.min_volume))
    if len(table) == 0:
        warnings.append(NO_BLOCK)

    surfaces = part_with_message(report, STEP_STARTS["surface"], STEP_STARTS["smooth"], "Conforming surfaces")
    surfaces(0.0)
    columns = block_columns(blocks, int(table.block_id.max()) if len(table) else 0)
    regions = region_volume(labels, blocks, overwrite_blocks=True)
    del labels, blocks  # before the surface's own grid-sized tables are made
    # The regions take 0.15 of the step, the faces' extraction the rest (the 1 km city).
    surfaces(0.15)
    surface = SurfaceModel.from_regions(grid, regions, progress=lambda share: surfaces(0.15 + 0.85 * share))
    del regions
    lap("surface")
    check_face_memory(len(surface.quads), grid.shape[0] * grid.shape[1], params.voxel_size, params.max_memory)

    box = (grid.origin, grid.origin + np.asarray(grid.shape) * h)
    roles = NodeRoles.of(surface, *box)
    nodes = surface.nodes
    stats: dict = {}
    if params.smoothing_iterations > 0:
        report(STEP_STARTS["smooth"], Text("Smoothing ({} passes)", params.smoothing_iterations))
        nodes, stats["smoothing"] = smooth(surface, roles, params.smoothing_iterations,
                                           params.quality_threshold, is_cancelled,
                                           part(report, STEP_STARTS["smooth"], STEP_STARTS["project_blocks"],
                                                "Smoothing"))
        lap("smooth")
    if params.project:
        report(STEP_STARTS["project_blocks"], "Projecting nodes onto the data")
        base = roles.on_block & roles.on_ground & ~roles.foot
        on_buildings = roles.on_block & ~base
        on_terrain = (roles.on_ground & ~roles.on_block) | base
        angle = params.max_projection_angle
        nodes, stats["projection_buildings"] = project_nodes(
            surface, nodes, roles, on_buildings, building, h, params.quality_threshold, angle,
            is_cancelled=is_cancelled, tree=building_search,
            progress=part(report, STEP_STARTS["project_blocks"], STEP_STARTS["project_ground"],
                          "Projecting block nodes"))
    # The ground data below serve the ground's projection only: they are not
    # held through the smoothing and the buildings' crossing control.
    if params.project:
        # Ground data for the ground and the base of the blocks: the ground points,
        # and the interpolated level where the ground was not seen (under roofs).
        xs, ys = grid.column_centres()
        ui, uj = np.nonzero(~level.observed)
        ground_data = np.concatenate([ground, np.column_stack([xs[ui], ys[uj], level.z[ui, uj]])])
        # Terrain nodes move along the (near vertical) terrain normal, away from
        # any other surface: the costly crossing test is kept for the buildings.
        ground_search = point_index(ground_data, COLUMN_VOXELS * h)
        nodes, stats["projection_ground"] = project_nodes(
            surface, nodes, roles, on_terrain, ground_data, h, params.quality_threshold, angle,
            check_crossings=False, is_cancelled=is_cancelled, tree=ground_search,
            progress=part(report, STEP_STARTS["project_ground"], STEP_STARTS["measure"], "Projecting ground nodes"))
        lap("project")
        # The ground points' search, for the distances measured below: the
        # ground points come first in the projection's data, and its compiled
        # index gives theirs without a new sort (a KD-tree: one made on a
        # thread of its own while the block nodes search the building points).
        # An index made beside the projection set the run's peak of memory
        # (a fresh run of the 1 km city: 2,051-2,136 MB, 1,846-1,858 without).
        ground_tree = search_of_first(ground_search, ground, COLUMN_VOXELS * h)
        del ground_data, ground_search
    else:
        ground_tree = in_background(point_index, ground, COLUMN_VOXELS * h)
    report(STEP_STARTS["measure"], "Measuring the blocks")
    mesh = SurfaceModel(nodes=nodes, quads=surface.quads, regions=surface.regions)
    # Distance of block nodes to the data (the nearest building or ground
    # point). Most block nodes are roofs and walls, high above any ground
    # point of the columns around them: they skip the ground's searches (on
    # the 1 km city, its first search then takes 171 k of 1.79 M nodes).
    # The distances took 0.93 s of the 1 km city's 1.59 s of measures.
    distances_end = STEP_STARTS["measure"] + 0.6 * (1 - STEP_STARTS["measure"])
    distance = np.full(len(nodes), np.nan)
    distance[roles.on_block] = nearest_distance(
        nodes[roles.on_block], [building_search, ground_tree], h, [None, near_ground.result()],
        lambda share: report(STEP_STARTS["measure"] + (distances_end - STEP_STARTS["measure"]) * share,
                             "Measuring the blocks"))
    del building_search, ground_tree, near_ground
    # The block faces' best splits, for the measures and then the layers' triangles.
    split = block_face_split(mesh, nodes)
    measures = measure_blocks(mesh, nodes, int(table.block_id.max()) if len(table) else 0, distance, split=split)
    lap("measure")
    report(1.0, Text("{} blocks", len(table)))
    stats["peak_rss_mb"] = peak_rss
    stats["n_points"] = {"ground": int(len(ground)), "building": int(len(building))}
    stats["n_voxels"] = int(grid.n_voxels)
    stats["n_faces"] = int(len(surface.quads))
    return Reconstruction(crs=crs, grid=grid, blocks=table, surface=surface, mesh=mesh,
                          measures=measures, footprint_columns=columns, warnings=warnings,
                          timings=timings, stats=stats, block_diagonal=split[0])


def _reconstruct_clusters(ground, building, ground_cluster, building_cluster, crs, params, airborne,
                          warnings, progress, is_cancelled, tiles) -> Reconstruction:
    """Reconstruct every cluster that has buildings on its own grid; merge."""
    wanted = np.unique(building_cluster)
    # Each cluster's share of the progress bar: its share of the points.
    # (Ground far from any building is a cluster of its own, left out.)
    n = int(max(ground_cluster.max(initial=0), building_cluster.max(initial=0))) + 1
    size = (np.bincount(ground_cluster, minlength=n) + np.bincount(building_cluster, minlength=n))[wanted]
    starts = np.concatenate([[0.0], np.cumsum(size)]) / max(size.sum(), 1)
    parts = []
    for n, c in enumerate(wanted):
        def part_progress(fraction: float, message: str, n: int = n) -> None:
            if progress is not None:
                progress(starts[n] + (starts[n + 1] - starts[n]) * fraction,
                         Text("Cluster {}/{}: {}", n + 1, len(wanted), message))
        own_ground = ground[ground_cluster == c]
        if len(own_ground) == 0:
            warnings.append(f"Skipped a cluster of {int((building_cluster == c).sum())} building points "
                            "with no ground point near it.")
            continue
        parts.append(reconstruct_points(own_ground, building[building_cluster == c], crs, params,
                                        airborne=airborne, progress=part_progress,
                                        is_cancelled=is_cancelled, split=False, tiles=tiles,
                                        overwrite_points=True))
    if not parts:
        raise UrbanvoxError("No cluster of building points has ground points near it.")
    result = merge_clusters(parts)
    result.warnings[:0] = warnings
    return result


def _roof_seeds(grid, building_cells, top_k, ground_observed, max_hole_cells):
    nx, ny, _ = grid.shape
    above = building_cells[:, 2] > top_k[building_cells[:, 0], building_cells[:, 1]]
    cells = building_cells[above]
    has_building = np.zeros((nx, ny), bool)
    has_building[cells[:, 0], cells[:, 1]] = True
    # Each column's highest building cell, in one compiled pass where np.maximum.at
    # took 0.08 s for the 1 km city's 752 k cells (floats: exact for cell numbers).
    highest = extreme_per_block(cells[:, 0] * ny + cells[:, 1], cells[:, 2], nx * ny - 1, largest=True,
                                initial=0.0)
    return roof_hole_columns(has_building, ground_observed, highest.reshape(nx, ny).astype(np.int64),
                             int(max_hole_cells))


def _peak_rss_mb() -> float:
    """Peak resident memory of this process so far (MB; NaN where unknown)."""
    try:
        import resource
    except ImportError:  # pragma: no cover - not on Windows
        return float("nan")
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _reporter(progress: Progress | None, is_cancelled: CancelCheck | None) -> Progress:
    def report(fraction: float, message: str) -> None:
        if is_cancelled is not None and is_cancelled():
            raise Cancelled()
        if progress is not None:
            progress(fraction, message)
    return report
