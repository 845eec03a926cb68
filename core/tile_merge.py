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

from . import jit
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
    The merged model is heading for about 1.2e+07 faces (from 1 tile done out of 4), which need
    about 1.8 GiB to merge, but only 1.0 GiB is available. Use a voxel size of at least 1.5, or a
    smaller area.
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
    chosen, node_of = number_nodes(copy_key, by_rank, ranks)
    del copy_key, by_rank
    # The outputs are allocated whole and filled piece by piece, and each
    # piece's arrays are dropped (and their memory handed back) once copied:
    # the pieces and the merged model are never held whole side by side
    # (the 2 km city's pieces hold 1.1 GB at 1 m, 4.5 GB at 0.5 m).
    nodes = np.empty((len(chosen), 3), dtype=np.float64)
    final = np.empty((len(chosen), 3), dtype=np.float64)
    all_quads = np.empty((sum(len(p.quads) for p in pieces), 4), dtype=np.int64)
    all_regions = np.empty((len(all_quads), 2), dtype=np.int32)
    columns = np.empty((sum(len(p.footprint_columns) for p in pieces), 3),
                       dtype=np.result_type(*(p.footprint_columns for p in pieces)))
    stop = columns_stop = n_blocks = 0
    for rank, p in enumerate(pieces):
        copies = slice(start[rank], start[rank + 1])
        place_nodes(nodes, final, node_of[copies], chosen, copies.start, p.keys, p.moved, h)
        rows = slice(stop, stop + len(p.quads))
        renumber = np.concatenate([[0], global_id[n_blocks:n_blocks + len(p.blocks)]]).astype(np.int32)
        place_faces(all_quads[rows], all_regions[rows], node_of[copies], p.quads, p.regions, renumber)
        stop = rows.stop
        fc = slice(columns_stop, columns_stop + len(p.footprint_columns))
        columns[fc] = p.footprint_columns
        columns[fc, 0] = renumber.take(p.footprint_columns[:, 0])
        columns_stop = fc.stop
        n_blocks += len(p.blocks)
        p.keys = p.moved = p.priority = p.quads = p.regions = p.footprint_columns = None
        if rank % 8 == 7:
            give_back()
    del chosen, node_of
    give_back()
    surface = SurfaceModel(nodes, all_quads, all_regions)
    mesh = SurfaceModel(final, all_quads, all_regions)
    columns = columns.take(np.lexsort((columns[:, 2], columns[:, 1], columns[:, 0])), axis=0)
    return grid, table, surface, mesh, measures, columns


def number_nodes(copy_key: np.ndarray, by_rank: np.ndarray, ranks: int) -> tuple[np.ndarray, np.ndarray]:
    """The nodes of the copies: each node's best-ranked copy (``chosen``) and
    each copy's node (``node_of``), nodes numbered in key order.

    ``copy_key`` is a copy's node key times ``ranks`` plus its rank,
    ``by_rank`` the copies sorted by it.

    Examples
    --------
    Copies 0 and 2 are of node 7 (copy 2 ranks first), copy 1 of node 4:

    >>> key = np.array([7 * 4 + 3, 4 * 4 + 1, 7 * 4 + 0])
    >>> chosen, node_of = number_nodes(key, np.argsort(key), 4)
    >>> chosen.tolist(), node_of.tolist()
    ([1, 2], [1, 0, 1])
    """
    # One pass instead of numpy's chain of (N,) passes (0.7-1.0 s on the
    # 2 km city's 20.5 M copies, a cumulative sum of booleans the slowest).
    found = jit.run("tiles_kernel", "number_nodes", copy_key, by_rank, ranks, size=len(copy_key))
    if found is not None:
        return found
    first = run_starts(copy_key.take(by_rank) // ranks)
    chosen = by_rank[first]
    node_of = np.empty(len(by_rank), dtype=np.int64)
    node_of[by_rank] = np.cumsum(first) - 1
    return chosen, node_of


def place_nodes(nodes: np.ndarray, final: np.ndarray, node_of: np.ndarray, chosen: np.ndarray, first: int,
                keys: np.ndarray, moved: np.ndarray, h: float) -> None:
    """Fill the rows of ``nodes`` (lattice positions times ``h``) and ``final``
    (moved positions) of the nodes whose chosen copy is one of a piece's.

    The piece's copies are numbered ``first, first + 1, ...``; ``node_of``
    holds their nodes, ``keys`` and ``moved`` their lattice index and moved
    position.

    Examples
    --------
    The piece's second copy is its node's chosen one, the first is not:

    >>> nodes, final = np.zeros((2, 3)), np.zeros((2, 3))
    >>> place_nodes(nodes, final, np.array([0, 1]), np.array([9, 6]), 5,
    ...             np.array([[1, 2, 3], [4, 5, 6]], np.int32), np.ones((2, 3)), 0.5)
    >>> nodes.tolist(), final.tolist()
    ([[0.0, 0.0, 0.0], [2.0, 2.5, 3.0]], [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    """
    # One pass over the piece's rows on all cores: on the 2 km city 0.15-0.25
    # s where numpy's row scatters took 1.3-1.8 s, after 0.4-0.7 s to sort the
    # chosen copies by piece. Where the tables' pages are fresh, their first
    # writes cost more than either (1.5 s in a run's merge).
    if jit.run("tiles_kernel", "place_nodes", nodes, final, node_of, chosen, first, keys, moved, h,
               size=len(keys)) is not None:
        return
    mine = chosen.take(node_of) == np.arange(first, first + len(node_of))
    here = node_of[mine]
    nodes[here] = keys[mine] * h
    final[here] = moved[mine]


def place_faces(quads_out: np.ndarray, regions_out: np.ndarray, node_of: np.ndarray, quads: np.ndarray,
                regions: np.ndarray, renumber: np.ndarray) -> None:
    """A piece's faces into their rows of the merged model: corners through
    ``node_of`` (the piece's copies' nodes), blocks (regions > 0) through
    ``renumber``, ground and air (< 0) as they are.

    Examples
    --------
    >>> quads_out, regions_out = np.zeros((1, 4), np.int64), np.zeros((1, 2), np.int32)
    >>> place_faces(quads_out, regions_out, np.array([10, 11, 12, 13]), np.array([[0, 1, 3, 2]]),
    ...             np.array([[1, -1]], np.int32), np.array([0, 5], np.int32))
    >>> quads_out.tolist(), regions_out.tolist()
    ([[10, 11, 13, 12]], [[5, -1]])
    """
    if jit.run("tiles_kernel", "place_faces", quads_out, regions_out, node_of, quads, regions, renumber,
               size=len(quads)) is not None:
        return
    # mode="clip" keeps take from buffering its output; every index is in range.
    np.take(node_of, quads, out=quads_out, mode="clip")
    regions_out[:] = renumbered_blocks(regions, renumber)


def renumbered_blocks(regions: np.ndarray, renumber: np.ndarray) -> np.ndarray:
    """``regions`` with the blocks (> 0) through ``renumber``, ground, air
    and outside (< 0) as they are.

    Examples
    --------
    >>> renumbered_blocks(np.array([[2, -1], [-2, 1]], np.int32), np.array([0, 7, 5], np.int32)).tolist()
    [[5, -1], [-2, 7]]
    """
    return np.where(regions > 0, renumber.take(np.maximum(regions, 0)), regions)
