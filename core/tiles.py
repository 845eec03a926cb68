"""Tiles: a large domain reconstructed piece by piece, locally or on Dask.

The domain's lattice (:class:`core.grid.GridWindow`) is cut into square tiles
of whole columns. Each tile is reconstructed on a *window*: its columns plus
a halo of ``halo`` columns on every side, with the domain's full height, so
that every step whose outcome depends on the neighbourhood of a voxel
(ground interpolation, smoothing, projection, crossing control) sees what a
single run sees. From each window only what the tile *owns* is kept:

* **Ownership of a block.** A block belongs to the tile that holds its
  *anchor*, the first column of its footprint in (i, j) order (the smallest
  i, then the smallest j). Every block has one anchor, so exactly one tile
  owns it, whatever the number of tiles it crosses.
* **Whole blocks.** A block is kept only when no voxel of it lies in the
  halo band of a window side that is not a domain side: it is then the same
  6-connected volume as in a single run. When an owned block reaches that
  band, the tile is run again on a window grown to the block's columns plus
  the halo, until its owned blocks are whole.
* **Ground and air faces** (between ground, air and the domain's outside)
  are kept by the tile whose columns hold the face's centre.

Pieces are merged on the global lattice (:mod:`core.tile_merge`): nodes are matched by their lattice
index (a node of several tiles takes its position from the tile owning a
block on it), blocks are numbered by their anchor in the order
``scipy.ndimage.label`` numbers a single run's, and each block's faces,
nodes, attributes and measures are those of its owning tile. Block counts
and volumes therefore equal a single run's (to rounding); ground and air
are the single run's wherever the halo covers what a node depends on.

Tiles run in this process, on a local Dask cluster (``workers=N``) or on
any Dask scheduler (``scheduler="tcp://host:8786"``, with urbanvox
importable on its workers), see :mod:`core.workers`.
:func:`reconstruct_tile` is a plain function of picklable inputs.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Callable

import numpy as np

from . import jit
from .blocks import BlockTable
from .errors import UrbanvoxError
from .grid import BIN_CHUNK, GridWindow
from .heap import give_back
from .ground import GroundLevel, column_ground_level
from .manifold import repair_height_field
from .measure import BlockMeasures
from .memory import available_memory, check_column_memory
from .parallel import in_background
from .progress import Text, part
from .reconstruction import NO_BLOCK, Reconstruction
from .surface import unique_nodes
from .tile_merge import check_copy_keys, check_merge_memory, merge_pieces, renumbered_blocks
from .workers import TileRunner

Columns = tuple[int, int, int, int]  # i0, j0, i1, j1 (half-open), global columns

#: The shares of a tiled run's progress bar before the tiles (the domain's
#: ground level, the points sorted by column) and after them (the merge):
#: 5.8 % and 1.5 % of the 1 km synthetic city's run in 500 m tiles here.
BEFORE_TILES, AFTER_TILES = 0.06, 0.02


@dataclass(frozen=True)
class TileOptions:
    """How to cut the domain and where to run the tiles.

    Attributes
    ----------
    tile_size : float
        Side of a tile (m); rounded to whole voxels.
    halo : float
        Width of the halo around a tile (m); at least 12 voxels are used.
    workers : int
        Local worker processes (Dask ``LocalCluster``); 0 or 1 runs the tiles
        one after the other in this process, without Dask.
    scheduler : str, optional
        Address of a running Dask scheduler; overrides ``workers``.
    """

    tile_size: float = 250.0
    halo: float = 10.0
    workers: int = 0
    scheduler: str | None = None

    def __post_init__(self):
        # Refused as the options are made, before the points are read.
        workers = 0 if self.workers is None else self.workers
        if not (isinstance(workers, (int, np.integer, float)) and math.isfinite(workers)
                and workers == int(workers) and workers >= 0):
            raise UrbanvoxError(f"The number of workers must be a whole number, 0 or 1 to run the tiles in this "
                                f"process, more for a local Dask cluster (got {self.workers}).")
        self.columns(1.0)  # the tile size

    def columns(self, voxel_size_m: float) -> tuple[int, int]:
        """Tile side and halo width in columns."""
        if not np.isfinite(self.tile_size) or self.tile_size <= 0:
            raise UrbanvoxError(f"The tile size must be a positive number of metres (got {self.tile_size}).")
        tile = max(1, int(round(self.tile_size / voxel_size_m)))
        halo = max(12, int(np.ceil(self.halo / voxel_size_m)))
        return tile, halo

    def cuts(self, window: GridWindow, voxel_size_m: float) -> bool:
        """Whether the tiles cut this window in more than one piece."""
        tile, _ = self.columns(voxel_size_m)
        return window.shape[0] > tile or window.shape[1] > tile


@dataclass
class TileJob:
    """Everything one tile needs; picklable, no QGIS, sent to a Dask worker."""

    index: int
    core: Columns
    window: Columns
    domain: GridWindow
    ground: np.ndarray    # world coordinates, cropped to the window
    building: np.ndarray
    level: GroundLevel    # the domain's ground level, cropped to the window
    crs_wkt: str
    params: "ReconstructionParams"  # noqa: F821 - core.inputs
    airborne: bool
    halo: int


@dataclass
class TilePiece:
    """What a tile owns, on the global lattice, or the window it must be rerun on."""

    index: int
    grow: Columns | None = None
    keys: np.ndarray | None = None        # (N, 3) global lattice index of every node
    moved: np.ndarray | None = None       # (N, 3) final node positions (domain's local coordinates)
    priority: np.ndarray | None = None    # (N,) True where an owned block uses the node
    quads: np.ndarray | None = None
    regions: np.ndarray | None = None     # owned blocks numbered 1..m in anchor order
    anchors: np.ndarray | None = None     # (m, 2) i, j of every owned block's anchor column
    blocks: BlockTable | None = None      # z relative to the domain
    measures: BlockMeasures | None = None
    footprint_columns: np.ndarray | None = None  # (P, 3): piece block id, global i, j
    warnings: list[str] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)


def plan_tiles(shape: tuple[int, int, int], tile: int) -> list[Columns]:
    """Square tiles of ``tile`` columns covering ``nx`` x ``ny`` columns.

    Examples
    --------
    >>> plan_tiles((5, 3, 10), 3)
    [(0, 0, 3, 3), (3, 0, 5, 3)]
    """
    nx, ny, _ = shape
    return [(i, j, min(i + tile, nx), min(j + tile, ny))
            for i in range(0, nx, tile) for j in range(0, ny, tile)]


def reconstruct_tile(job: TileJob, progress: Callable[[float, str], None] | None = None,
                     is_cancelled: Callable[[], bool] | None = None) -> TilePiece:
    """Reconstruct one tile's window and keep what the tile owns.

    A window with building points but no ground point (a tile under one
    large roof) is grown: the ground level comes from the data around it.
    """
    import pyproj

    from .pipeline import reconstruct_points

    i0, j0, i1, j1 = job.window
    if len(job.ground) == 0:
        nx, ny, _ = job.domain.shape
        if (i0, j0, i1, j1) == (0, 0, nx, ny):
            return TilePiece(job.index)
        step = max(job.halo, (job.core[2] - job.core[0]))
        return TilePiece(job.index, grow=(max(0, i0 - step), max(0, j0 - step),
                                          min(nx, i1 + step), min(ny, j1 + step)))
    crs = pyproj.CRS.from_wkt(job.crs_wkt)
    result = reconstruct_points(job.ground, job.building, crs, job.params, airborne=job.airborne,
                                split=False, window=job.domain.columns(i0, j0, i1, j1),
                                ground_level=job.level, progress=progress, is_cancelled=is_cancelled)
    return _owned_piece(job, result)


def _owned_piece(job: TileJob, result) -> TilePiece:
    """The blocks anchored in the tile's core (or the window to grow), and
    the ground and air faces centred in the core."""
    i0, j0, i1, j1 = job.window
    ci0, cj0, ci1, cj1 = job.core
    nx, ny, _ = job.domain.shape
    halo = job.halo
    table = result.blocks
    n = len(table)
    fc = result.footprint_columns
    gi, gj = fc[:, 1] + i0, fc[:, 2] + j0
    ids = fc[:, 0]
    # Anchor: the first column in (i, j) order; footprint columns are sorted
    # by block, then i, then j.
    first = np.searchsorted(ids, table.block_id)
    anchor_i, anchor_j = gi[first], gj[first]
    owned = (anchor_i >= ci0) & (anchor_i < ci1) & (anchor_j >= cj0) & (anchor_j < cj1)
    lo_i, hi_i = _per_block(ids, gi, n)
    lo_j, hi_j = _per_block(ids, gj, n)
    cut = (((lo_i < i0 + halo) & (i0 > 0)) | ((hi_i >= i1 - halo) & (i1 < nx))
           | ((lo_j < j0 + halo) & (j0 > 0)) | ((hi_j >= j1 - halo) & (j1 < ny)))
    if (owned & cut).any():
        sel = owned & cut
        grow = (max(0, min(i0, int(lo_i[sel].min()) - halo)), max(0, min(j0, int(lo_j[sel].min()) - halo)),
                min(nx, max(i1, int(hi_i[sel].max()) + 1 + halo)), min(ny, max(j1, int(hi_j[sel].max()) + 1 + halo)))
        return TilePiece(job.index, grow=grow)

    h = result.grid.voxel_size
    surface, mesh = result.surface, result.mesh
    keys = np.rint(surface.nodes / h).astype(np.int32)  # local coordinates are the domain's
    # Owned blocks, numbered in anchor order (scipy.ndimage.label's order in a
    # single run: the first voxel in (i, j, k) raster order).
    own_ids = table.block_id[owned]
    order = np.lexsort((table.ground_z[owned], anchor_j[owned], anchor_i[owned]))
    renumber = np.zeros(n + 1, dtype=np.int32)
    renumber[own_ids[order]] = np.arange(1, len(own_ids) + 1, dtype=np.int32)
    regions, quads = surface.regions, surface.quads
    keep, keep_block = owned_faces(keys, quads, regions, renumber, job.core, (nx, ny))
    # take and compress: row gathers faster than indexing (core.vectors).
    quads = quads.compress(keep, axis=0)
    used, inverse = unique_nodes(quads, len(surface.nodes))
    kept_regions = regions.compress(keep, axis=0)
    new_regions = renumbered_blocks(kept_regions, renumber)
    priority = np.zeros(len(surface.nodes), dtype=bool)
    priority[surface.quads.compress(keep_block, axis=0).ravel()] = True

    rows = np.flatnonzero(owned)[order]
    blocks = table.select(rows)
    measures = result.measures.select(own_ids[order] - 1)
    fc_keep = renumber[ids] > 0
    columns = np.column_stack([renumber[ids[fc_keep]], gi[fc_keep], gj[fc_keep]])
    columns = columns.take(np.lexsort((columns[:, 2], columns[:, 1], columns[:, 0])), axis=0)
    return TilePiece(
        job.index, keys=keys.take(used, axis=0), moved=mesh.nodes.take(used, axis=0), priority=priority[used],
        quads=inverse.reshape(quads.shape).astype(np.int32), regions=new_regions.astype(np.int32),
        anchors=np.column_stack([anchor_i[rows], anchor_j[rows]]), blocks=blocks, measures=measures,
        footprint_columns=columns, warnings=list(result.warnings), timings=dict(result.timings))


def owned_faces(keys: np.ndarray, quads: np.ndarray, regions: np.ndarray, renumber: np.ndarray, core: Columns,
                columns: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """The faces a tile keeps: those of its owned blocks, and the ground and
    air faces whose centre lies in its core.

    Parameters
    ----------
    keys : ndarray of int (N, 3)
        Lattice index of every node (the domain's).
    quads, regions : ndarray (F, 4), (F, 2)
        The window's faces and the regions on their two sides (blocks > 0).
    renumber : ndarray of int
        Non-zero for the owned blocks (indexed by block id, 0 for ground and air).
    core : (i0, j0, i1, j1)
        The tile's core columns; a centre on the domain's far side
        (``columns``, nx and ny) belongs to the last tile.

    Returns
    -------
    keep, keep_block : ndarray of bool (F,)
        The faces kept, and those of them on an owned block.

    Examples
    --------
    A face of block 1 (owned), an air face centred in the core (i from 0 to
    2) and one centred outside it:

    >>> keys = np.array([[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1], [2, 0, 1], [2, 1, 1], [3, 0, 1], [3, 1, 1]])
    >>> quads = np.array([[0, 1, 2, 3], [1, 4, 5, 2], [4, 6, 7, 5]])
    >>> regions = np.array([[1, -2], [-1, -2], [-1, -2]])
    >>> keep, block = owned_faces(keys, quads, regions, np.array([0, 1]), (0, 0, 2, 5), (9, 5))
    >>> keep.tolist(), block.tolist()
    ([True, True, False], [True, False, False])
    """
    ci0, cj0, ci1, cj1 = core
    nx, ny = columns
    # One pass over the faces on all cores (core.tiles_kernel), the same
    # tests: 19 -> 4 ms a tile on the 2 km city.
    found = jit.run("tiles_kernel", "owned_faces", keys, quads, regions, renumber, core, columns, size=len(quads))
    if found is not None:
        return found
    positive = np.where(regions > 0, regions, 0)
    # Two columns and four corners each summed apart: numpy's any() and
    # sum() along rows of two or four are slow on millions of faces.
    block_face = (regions[:, 0] > 0) | (regions[:, 1] > 0)
    keep_block = (renumber[positive[:, 0]] > 0) | (renumber[positive[:, 1]] > 0)
    # The face's centre in lattice units, times 4: the sum of its corners
    # (exact integers, so the tests are those on the mean).
    centre = []
    for c in range(2):
        # One gather of the four corners from a contiguous column: half the
        # time of four gathers through the strided column (0.44 -> 0.20 s on
        # the 1 km city's 4.9 M quads).
        corners = keys[:, c].astype(np.int64).take(quads)
        centre.append(corners[:, 0] + corners[:, 1] + corners[:, 2] + corners[:, 3])
    in_core = ((centre[0] >= 4 * ci0) & ((centre[0] < 4 * ci1) | (ci1 == nx))
               & (centre[1] >= 4 * cj0) & ((centre[1] < 4 * cj1) | (cj1 == ny)))
    return keep_block | (~block_face & in_core), keep_block


def _per_block(ids: np.ndarray, values: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Smallest and largest ``values`` of each block (or group) ``1..n`` (ids
    ``ids``); the int64 extremes for a block without values.

    Reduced over the runs of equal ids (sorted first if they are not: the
    footprint columns are), not with ``np.minimum.at``, which took 3 ms per
    call on a tile's 40 k columns (four calls per tile).

    Examples
    --------
    >>> lo, hi = _per_block(np.array([2, 1, 2, 2]), np.array([5, 7, 3, 9]), 3)
    >>> lo.tolist()[:2], hi.tolist()[:2], bool(lo[2] > hi[2])
    ([7, 3], [7, 9], True)
    """
    lo = np.full(n + 1, np.iinfo(np.int64).max)
    hi = np.full(n + 1, np.iinfo(np.int64).min)
    if len(ids):
        if not (ids[1:] >= ids[:-1]).all():
            order = np.argsort(ids, kind="stable")
            ids, values = ids[order], values[order]
        starts = np.flatnonzero(np.concatenate([[True], ids[1:] != ids[:-1]]))
        lo[ids[starts]] = np.minimum.reduceat(values, starts)
        hi[ids[starts]] = np.maximum.reduceat(values, starts)
    return lo[1:], hi[1:]


def reconstruct_tiled(ground: np.ndarray, building: np.ndarray, crs, params, airborne: bool,
                      domain: GridWindow, options: TileOptions, warnings: list[str],
                      progress: Callable[[float, str], None] | None,
                      is_cancelled: Callable[[], bool] | None):
    """Reconstruct ``domain`` tile by tile (see the module) and merge."""
    from .crs import metres_per_unit

    start = time.perf_counter()
    progress = _monotone(progress)
    if progress is not None:
        progress(0.0, "Cutting the domain into tiles")
    m = metres_per_unit(crs)
    h = params.voxel_size / m
    tile, halo = options.columns(params.voxel_size)
    check_column_memory(domain.shape[:2], params.voxel_size, params.max_memory)
    cores = plan_tiles(domain.shape, tile)
    check_copy_keys(domain, len(cores))  # before the tiles run, not at their merge
    # The ground level is a 2-D field, small next to the grid: computed once for
    # the domain, so that every tile sees the single run's ground (its gaps
    # under large roofs are interpolated from rims that may lie in other tiles).
    # On a thread of its own while the points are sorted by column (the
    # 2 km city: the level 1.9 s, 0.5 s of it the gaps' fill, the cropper
    # 1.7 s).
    domain_level = in_background(partial(column_ground_level, world=True), domain.grid(h), ground)
    crop = _Cropper(ground, building, domain, h)
    level = domain_level.result()
    level = GroundLevel(level.z, repair_height_field(level.top_k), level.observed)

    windows = initial_windows(cores, tile, halo, domain, _building_columns(building, level, domain, h))
    workers = max(1, int(options.workers or 1)) if not options.scheduler else None
    # The read's chunks and the sorts above leave gigabytes free in this
    # process's heap (2.3 GB on the 2 km city), kept for reuse by the run;
    # with workers, nothing here reuses them before the merge, while the
    # workers' memory adds to it.
    if workers is None or workers > 1:
        give_back()
    # Several tiles at once share the memory; the merge has it all (the
    # workers are gone by then).
    budget = params.max_memory or available_memory()
    tile_params = replace(params, extent=None, max_memory=int(budget / (workers or 1)))

    def job(index: int, window: Columns) -> TileJob:
        g, b = crop(window)
        i0, j0, i1, j1 = window
        cut = (slice(i0, i1), slice(j0, j1))
        return TileJob(index, cores[index], window, domain, g, b,
                       GroundLevel(level.z[cut], level.top_k[cut], level.observed[cut]),
                       crs.to_wkt(), tile_params, airborne, halo)

    done: list[TilePiece] = []
    regrown = 0
    done_faces = done_columns = 0  # what the pieces so far own, for the merge's memory
    with TileRunner(options, job, reconstruct_tile) as runner:
        for n, window in enumerate(windows):
            runner.submit(n, window)
        # Each tile's share of the bar: its share of the domain's columns (a
        # tile's time goes with its ground as much as with its buildings).
        areas = np.array([(i1 - i0) * (j1 - j0) for i0, j0, i1, j1 in cores], dtype=np.float64)
        tiles_progress = part(progress, BEFORE_TILES, 1.0 - AFTER_TILES)
        for piece in runner.run(is_cancelled, tiles_progress, list(areas / areas.sum())):
            if piece.grow is not None:
                regrown += 1
                runner.submit(piece.index, piece.grow)
            else:
                done.append(piece)
                ci0, cj0, ci1, cj1 = cores[piece.index]
                done_columns += (ci1 - ci0) * (cj1 - cj0)
                done_faces += 0 if piece.quads is None else len(piece.quads)
                check_merge_memory(done_faces, done_columns, len(done), len(cores), domain.shape, budget,
                                   params.voxel_size)
    done.sort(key=lambda p: p.index)
    if progress is not None:
        progress(1.0 - AFTER_TILES, "Merging the tiles")
    grid, table, surface, mesh, measures, columns = merge_pieces(done, domain, h)
    timings: dict[str, float] = {}
    for p in done:
        for stage, seconds in p.timings.items():
            timings[stage] = timings.get(stage, 0.0) + seconds
    timings["tiles_wall"] = time.perf_counter() - start
    warnings.extend(_tile_warnings(done))
    warnings.append(f"Reconstructed in {len(cores)} tiles of {tile * h * m:g} m "
                    f"({regrown} rerun on a larger window for blocks crossing their halo).")
    if len(table) == 0 and NO_BLOCK not in warnings:
        warnings.append(NO_BLOCK)
    if progress is not None:
        progress(1.0, Text("{} blocks", len(table)))
    return Reconstruction(crs=crs, grid=grid, blocks=table, surface=surface, mesh=mesh, measures=measures,
                          footprint_columns=columns, warnings=warnings, timings=timings,
                          stats={"tiles": len(cores), "tiles_rerun": regrown,
                                 "workers": options.scheduler or workers,
                                 "n_points": {"ground": int(len(ground)), "building": int(len(building))},
                                 "n_voxels": int(grid.n_voxels), "n_faces": int(len(surface.quads))})


def _tile_warnings(pieces: list[TilePiece]) -> list[str]:
    """The tiles' warnings, each kind once: counts of a tile include its halo,
    so a warning several tiles give with different counts is reported with
    the number of tiles; one they give word for word, as it is (a run of
    clusters then says it once too)."""
    import re

    kinds: dict[str, list[str]] = {}
    for piece in pieces:
        for text in piece.warnings:
            if text != NO_BLOCK:  # a tile owning no block
                kinds.setdefault(re.sub(r"[\d.,]+", "#", text), []).append(text)
    out = []
    for texts in kinds.values():
        if len(set(texts)) == 1:
            out.append(texts[0])
        else:
            out.append(f"{texts[0].rstrip('.')} (said by {len(texts)} tiles, this is the first; "
                       "a tile counts its halo too).")
    return out


def _monotone(progress: Callable[[float, str], None] | None) -> Callable[[float, str], None] | None:
    """Progress that never goes back (a tile run again restarts its own count)."""
    if progress is None:
        return None
    best = [0.0]

    def report(fraction: float, message: str) -> None:
        best[0] = max(best[0], float(fraction))
        progress(best[0], message)
    return report


def _building_columns(building: np.ndarray, level: GroundLevel, domain: GridWindow, h: float) -> np.ndarray:
    """Columns of the domain holding a building point above the ground level."""
    nx, ny, _ = domain.shape
    i = _column(building[:, 0], domain.lower[0], h, nx)
    j = _column(building[:, 1], domain.lower[1], h, ny)
    above = building[:, 2] - domain.lower[2] > level.z[i, j] + 0.5 * h
    mask = np.zeros((nx, ny), dtype=bool)
    mask[i[above], j[above]] = True
    return mask


def initial_windows(cores: list[Columns], tile: int, halo: int, domain: GridWindow,
                    building_columns: np.ndarray) -> list[Columns]:
    """Each tile's core and halo, grown to cover the likely blocks it owns.

    The blocks are not known before the tiles run; the 8-connected groups of
    columns holding building points (dilated by two columns for the voxels
    the method adds) contain them. A tile's window is grown to the groups
    whose first column in (i, j) order is in its core, plus the halo, which
    saves most reruns (:func:`reconstruct_tile` still grows a window when a
    block it owns reaches the halo).

    Examples
    --------
    >>> w = GridWindow(np.zeros(3), (40, 10, 5))
    >>> mask = np.zeros((40, 10), bool); mask[5:30, 4] = True   # one long block
    >>> cores = plan_tiles(w.shape, 10)
    >>> initial_windows(cores, 10, 2, w, mask)[:2]
    [(0, 0, 34, 10), (8, 0, 22, 10)]
    """
    from scipy import ndimage

    nx, ny, _ = domain.shape
    core = np.array(cores, dtype=np.int64).reshape(-1, 4)
    windows = np.column_stack([np.maximum(0, core[:, 0] - halo), np.maximum(0, core[:, 1] - halo),
                               np.minimum(nx, core[:, 2] + halo), np.minimum(ny, core[:, 3] + halo)])
    mask = ndimage.binary_dilation(building_columns, iterations=2, structure=np.ones((3, 3), bool))
    groups, n = ndimage.label(mask, structure=np.ones((3, 3), bool))
    if n > 0:
        gi, gj = np.nonzero(groups)
        label = groups[gi, gj]
        order = np.lexsort((gj, gi, label))  # by group, then i, then j
        first = order[np.unique(label[order], return_index=True)[1]]
        tiles_y = -(-ny // tile)
        owner = (gi[first] // tile) * tiles_y + gj[first] // tile  # plan_tiles order: i major
        lo_i, hi_i = _per_block(label, gi, n)
        lo_j, hi_j = _per_block(label, gj, n)
        np.minimum.at(windows[:, 0], owner, np.maximum(0, lo_i - halo))
        np.minimum.at(windows[:, 1], owner, np.maximum(0, lo_j - halo))
        np.maximum.at(windows[:, 2], owner, np.minimum(nx, hi_i + 1 + halo))
        np.maximum.at(windows[:, 3], owner, np.minimum(ny, hi_j + 1 + halo))
    return [tuple(int(v) for v in w) for w in windows]


class _Cropper:
    """The points of a window of columns, found through one sort by column.

    Keeps the sort order and the columns of every point (4 + 2 + 2 bytes a
    point, :func:`_column`), not a sorted copy of the points (24 bytes): on a
    city of 50 M points 0.4 GB instead of 1.2 GB.
    """

    def __init__(self, ground: np.ndarray, building: np.ndarray, domain: GridWindow, h: float):
        self.sets = []
        index = np.int32 if max(len(ground), len(building)) < 2**31 else np.int64
        for points in (ground, building):
            i = _column(points[:, 0], domain.lower[0], h, domain.shape[0])
            # The same order in one compiled pass (core.grid_kernel).
            order = jit.run("grid_kernel", "column_order", i, domain.shape[0], index, size=len(i))
            if order is None:
                order = np.argsort(i, kind="stable").astype(index)
            j = _column(points[:, 1], domain.lower[1], h, domain.shape[1])[order]
            self.sets.append((points, order, i[order], j))

    def __call__(self, window: Columns) -> tuple[np.ndarray, np.ndarray]:
        i0, j0, i1, j1 = window
        out = []
        for points, order, i, j in self.sets:
            # Bounds in the columns' own dtype: a list of Python ints would
            # make searchsorted cast all the columns to int64 on every call.
            a, b = np.searchsorted(i, np.array([i0, i1], dtype=i.dtype))
            inside = (j[a:b] >= j0) & (j[a:b] < j1)
            out.append(points.take(order[a:b].compress(inside), axis=0))  # take: faster rows (core.vectors)
        return out[0], out[1]


def _column(x: np.ndarray, lower: float, h: float, n: int) -> np.ndarray:
    """Column index of coordinates ``x`` on a lattice of ``n`` columns.

    As uint16 below 65,535 columns (else int32): numpy's stable sort of
    16-bit integers is a radix sort, seven times faster (the cropper's sort
    of 50 M points took 2.5 s), and the same order.
    """
    out = np.empty(len(x), dtype=np.uint16 if n < 2**16 - 1 else np.int32)
    # The same cells in one pass on all cores (core.grid_kernel): 1.1 -> 0.1 s
    # for the 2 km city's 50 M points' x.
    if jit.run("grid_kernel", "axis_cells", x, lower, h, n, out, size=len(x)) is not None:
        return out
    # A chunk at a time: the temporaries stay in the cache instead of
    # faulting in fresh pages for every point (0.23 -> 0.14 s for the 2 km
    # city's 35 M ground points' x).
    for start in range(0, len(x), BIN_CHUNK):
        column = x[start:start + BIN_CHUNK] - lower
        column /= h
        np.floor(column, out=column)
        np.clip(column, 0, n - 1, out=column)
        out[start:start + len(column)] = column
    return out
