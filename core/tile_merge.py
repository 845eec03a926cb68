"""The tiles' pieces merged into one model (:mod:`core.tiles`), and the
memory that merge needs.

Each tile returns a :class:`core.tiles.TilePiece`: the nodes it has, keyed by
their index on the domain's lattice, the faces it owns and the blocks it
owns with their attributes. :func:`merge_pieces` matches the nodes of all
pieces on the lattice (a node of several tiles takes its position from the
tile owning a block on it), numbers the blocks by their anchor column in
the order ``scipy.ndimage.label`` numbers a single run's, and fills one
surface, one mesh and one block table, consuming the pieces as it goes.
:func:`check_merge_memory` stops a run early when the merge will not fit.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .blocks import BlockTable
from .errors import UrbanvoxError
from .grid import GridWindow
from .heap import give_back
from .measure import BlockMeasures
from .surface import SurfaceModel
from .topology import run_starts

if TYPE_CHECKING:
    from .tiles import TilePiece


def check_copy_keys(domain: GridWindow, n_tiles: int) -> None:
    """The merge's keys (lattice node number x 2 tiles + rank) must fit 64 bits."""
    nx1, ny1, nz1 = (size + 1 for size in domain.shape)
    if nx1 * ny1 * nz1 * 2 * n_tiles >= np.iinfo(np.int64).max:
        raise UrbanvoxError(
            f"The domain's {nx1 * ny1 * nz1:.3g} lattice nodes in {n_tiles} tiles are more than the merge "
            "can number: use larger tiles or voxels, or a smaller extent.")


#: Bytes per face of the merged model while :func:`merge_pieces` makes it,
#: the pieces it consumes included: 120 B on the 2 km city at 1 m (19.0 M
#: faces), 131 B at 0.5 m (76.4 M faces), with a margin.
MERGE_BYTES_PER_FACE = 160


def check_merge_memory(faces: int, columns: int, tiles_done: int, n_tiles: int, shape: tuple[int, int, int],
                       available: int, voxel_size: float) -> int:
    """Refuse to go on once the tiles done show that their merge will not fit.

    The merged model is the whole domain's: its faces are extrapolated from
    the ``faces`` the tiles done own, per column of their cores (``columns``
    in all), once they cover a tenth of the domain (the last tile gives the
    exact count, before the merge allocates). Returns the estimate in bytes
    (0 before a tenth).

    Examples
    --------
    The first of four tiles owns 3 M faces:

    >>> check_merge_memory(3_000_000, 500 * 500, 1, 4, (1000, 1000, 50), 8 * 2**30, 1.0)
    1920000000
    >>> try:
    ...     check_merge_memory(3_000_000, 500 * 500, 1, 4, (1000, 1000, 50), 2**30, 1.0)
    ... except UrbanvoxError as error:
    ...     print(error)
    The merged model is heading for about 1.2e+07 faces (from 1 tile done out of 4), which need about 1.8 GiB to merge, but only 1.0 GiB is available. Use a voxel size of at least 1.5, or a smaller area.
    """
    total = shape[0] * shape[1]
    if columns < 0.1 * total:
        return 0
    faces = faces * total / columns
    needed = int(faces * MERGE_BYTES_PER_FACE)
    if needed > available:
        factor = np.sqrt(needed / available)  # faces scale with 1 / size²
        suggestion = np.ceil(voxel_size * factor * 1.05 * 10) / 10
        done = f"{tiles_done} tile{'s' if tiles_done > 1 else ''} done out of {n_tiles}"
        raise UrbanvoxError(
            f"The merged model is heading for about {faces:.2g} faces (from {done}), which need about "
            f"{needed / 2**30:.1f} GiB to merge, but only {available / 2**30:.1f} GiB is available. "
            f"Use a voxel size of at least {suggestion:g}, or a smaller area.")
    return needed


def merge_pieces(pieces: "list[TilePiece]", domain: GridWindow, voxel_size: float):
    """One :class:`~core.reconstruction.Reconstruction` body from the tiles' pieces.

    Returns the grid, block table, surface, mesh, measures and footprint
    columns (the caller adds CRS, warnings and statistics). The pieces'
    arrays are consumed: each piece's are dropped once they are merged.
    """
    pieces = [p for p in pieces if p.keys is not None]
    h = voxel_size
    grid = domain.grid(h)
    if not pieces:
        raise UrbanvoxError("No tile holds data.")
    # Global block numbers: sort every owned block by its anchor.
    anchors = np.concatenate([p.anchors for p in pieces])
    lowest = np.concatenate([p.blocks.ground_z for p in pieces])
    order = np.lexsort((lowest, anchors[:, 1], anchors[:, 0]))
    global_id = np.empty(len(order), dtype=np.int32)
    global_id[order] = np.arange(1, len(order) + 1, dtype=np.int32)
    by_id = np.argsort(global_id)
    table = BlockTable.concatenate([p.blocks for p in pieces]).select(by_id)
    table.block_id = np.arange(1, len(by_id) + 1, dtype=np.int64)
    measures = BlockMeasures.concatenate([p.measures for p in pieces]).select(by_id)

    # Every copy of a node (one per tile that has it) gets a key: the node's
    # lattice number, then its rank, the tile's place in the list, owned
    # blocks' nodes first, so that a block's nodes come from its tile. Made
    # piece by piece: the 2 km city's 25 pieces hold 19 M nodes, and tables
    # of all their copies (keys, ranks, moved positions) cost gigabytes of
    # fresh memory.
    check_copy_keys(domain, len(pieces))
    nx1, ny1, _ = (size + 1 for size in domain.shape)
    ranks = 2 * len(pieces)
    start = np.cumsum([0] + [len(p.keys) for p in pieces])
    copy_key = np.empty(int(start[-1]), dtype=np.int64)
    for rank, p in enumerate(pieces):
        flat = p.keys[:, 0].astype(np.int64) + nx1 * (p.keys[:, 1] + ny1 * p.keys[:, 2].astype(np.int64))
        copy_key[start[rank]:start[rank + 1]] = flat * ranks + np.where(p.priority, rank, rank + len(pieces))
    # Sorted by node, then rank: each piece's nodes come in lattice order, so
    # timsort (the stable sort) merges those runs; the keys are unique, so it
    # gives any sort's order.
    by_rank = np.argsort(copy_key, kind="stable")
    node_key = copy_key.take(by_rank) // ranks
    del copy_key
    first = run_starts(node_key)  # a node's best-ranked copy
    del node_key
    chosen = by_rank[first]
    node_of = np.empty(len(by_rank), dtype=np.int64)
    node_of[by_rank] = np.cumsum(first) - 1
    del by_rank, first
    # Each node's lattice position and moved position from its chosen copy.
    piece_of = np.searchsorted(start, chosen, side="right") - 1
    if len(pieces) <= np.iinfo(np.int16).max:
        piece_of = piece_of.astype(np.int16)  # numpy's stable sort of 16-bit keys is a radix sort
    by_piece = np.argsort(piece_of, kind="stable")
    bounds = np.searchsorted(piece_of.take(by_piece), np.arange(len(pieces) + 1))
    del piece_of
    # The outputs are allocated whole and filled piece by piece, and each
    # piece's arrays are dropped (and their memory handed back) once copied:
    # the pieces and the merged model are never held whole side by side
    # (the 2 km city's pieces hold 1.1 GB at 1 m, 4.5 GB at 0.5 m).
    lattice = np.empty((len(chosen), 3), dtype=pieces[0].keys.dtype)
    final = np.empty((len(chosen), 3), dtype=np.float64)
    all_quads = np.empty((sum(len(p.quads) for p in pieces), 4), dtype=np.int64)
    all_regions = np.empty((len(all_quads), 2), dtype=np.int32)
    columns = np.empty((sum(len(p.footprint_columns) for p in pieces), 3),
                       dtype=np.result_type(*(p.footprint_columns for p in pieces)))
    stop = columns_stop = n_blocks = 0
    for rank, p in enumerate(pieces):
        nodes_here = by_piece[bounds[rank]:bounds[rank + 1]]
        copies = chosen.take(nodes_here) - start[rank]
        # take: row gathers faster than indexing (core.vectors).
        lattice[nodes_here] = p.keys.take(copies, axis=0)
        final[nodes_here] = p.moved.take(copies, axis=0)
        # The piece's quads through its own stretch of node_of, straight into
        # their rows (mode="clip" keeps take from buffering its output; every
        # index is in range).
        rows = slice(stop, stop + len(p.quads))
        np.take(node_of[start[rank]:start[rank + 1]], p.quads, out=all_quads[rows], mode="clip")
        renumber = np.concatenate([[0], global_id[n_blocks:n_blocks + len(p.blocks)]]).astype(np.int32)
        np.copyto(all_regions[rows], p.regions)
        np.copyto(all_regions[rows], renumber.take(np.maximum(p.regions, 0)), where=p.regions > 0)
        stop = rows.stop
        fc = slice(columns_stop, columns_stop + len(p.footprint_columns))
        columns[fc] = p.footprint_columns
        columns[fc, 0] = renumber.take(p.footprint_columns[:, 0])
        columns_stop = fc.stop
        n_blocks += len(p.blocks)
        p.keys = p.moved = p.priority = p.quads = p.regions = p.footprint_columns = None
        if rank % 8 == 7:
            give_back()
    del by_piece, chosen, node_of
    give_back()
    nodes = lattice.astype(np.float64)
    del lattice
    nodes *= h
    surface = SurfaceModel(nodes, all_quads, all_regions)
    mesh = SurfaceModel(final, all_quads, all_regions)
    columns = columns.take(np.lexsort((columns[:, 2], columns[:, 1], columns[:, 0])), axis=0)
    return grid, table, surface, mesh, measures, columns
