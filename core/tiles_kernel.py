"""Compiled passes of the tiled run (numba, :mod:`core.jit`).

Each tile keeps the faces it owns (:func:`core.tiles.owned_faces`): numpy
tests them in a dozen whole-array passes, the centres through gathers of
the corners' lattice indices: 19 ms a tile of about 290 k faces on the
2 km synthetic city. Here one pass on all cores tests each face: 4 ms.

:func:`core.tile_merge.merge_pieces` numbers the nodes of all pieces (one
per lattice node, from the copies the tiles hold) and copies every piece's
nodes and faces into the merged model. numpy writes the numbering as a
chain of whole-array passes over the copies (a gather, a division, a
cumulative sum of booleans, a scatter) and the copies as row scatters after
an argsort of the chosen copies by piece: on the 2 km synthetic city's
20.5 M copies, 19 M nodes and 19 M faces, 4.7-7.3 s of the merge. Here the
numbering is one pass over the sorted copies and each piece's nodes and
faces one pass on all cores, with the same numbers: positions are the same
products, the rest integers.
"""
from __future__ import annotations

import numpy as np

from .neighbours_kernel import compiled
from .parallel import map_blocks, thread_blocks


def owned_faces(keys: np.ndarray, quads: np.ndarray, regions: np.ndarray, renumber: np.ndarray,
                core: tuple[int, int, int, int], columns: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """:func:`core.tiles.owned_faces`.

    Examples
    --------
    Two air faces centred at x = 0.5 and 1.5 (4 x = 2 and 6): a core of the
    first column keeps the first; as the domain's last column (nx = 1) it
    keeps what lies beyond too:

    >>> keys = np.array([[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1], [2, 0, 1], [2, 1, 1]], np.int32)
    >>> quads = np.array([[0, 1, 2, 3], [1, 4, 5, 2]])
    >>> regions = np.array([[-1, -2], [-1, -2]], np.int32)
    >>> for columns in ((2, 1), (1, 1)):
    ...     print(owned_faces(keys, quads, regions, np.zeros(1, np.int32), (0, 0, 1, 1), columns)[0].tolist())
    [True, False]
    [True, True]
    """
    keys, quads = np.ascontiguousarray(keys), np.ascontiguousarray(quads)
    regions, renumber = np.ascontiguousarray(regions), np.ascontiguousarray(renumber)
    keep = np.empty(len(quads), dtype=np.bool_)
    keep_block = np.empty(len(quads), dtype=np.bool_)
    i0, j0, i1, j1 = (int(v) for v in core)
    nx, ny = int(columns[0]), int(columns[1])
    map_blocks(lambda rows: _owned(keys, quads, regions, renumber, i0, j0, i1, j1, nx, ny, rows.start, rows.stop,
                                   keep, keep_block), thread_blocks(len(quads)))
    return keep, keep_block


def number_nodes(copy_key: np.ndarray, by_rank: np.ndarray, ranks: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`core.tile_merge.number_nodes`.

    Examples
    --------
    >>> key = np.array([7 * 4 + 3, 4 * 4 + 1, 7 * 4 + 0])
    >>> chosen, node_of = number_nodes(key, np.argsort(key), 4)
    >>> chosen.tolist(), node_of.tolist()
    ([1, 2], [1, 0, 1])
    """
    node_of = np.empty(len(by_rank), dtype=np.int64)
    chosen = np.empty(len(by_rank), dtype=np.int64)
    n = _number(np.ascontiguousarray(copy_key), np.ascontiguousarray(by_rank), int(ranks), chosen, node_of)
    return chosen[:n], node_of  # a view: the copies' spare rows are a few percent


def place_nodes(nodes: np.ndarray, final: np.ndarray, node_of: np.ndarray, chosen: np.ndarray, first: int,
                keys: np.ndarray, moved: np.ndarray, h: float) -> bool:
    """:func:`core.tile_merge.place_nodes`; True.

    Examples
    --------
    >>> nodes, final = np.zeros((2, 3)), np.zeros((2, 3))
    >>> place_nodes(nodes, final, np.array([0, 1]), np.array([9, 6]), 5,
    ...             np.array([[1, 2, 3], [4, 5, 6]], np.int32), np.ones((2, 3)), 0.5)
    True
    >>> nodes[1].tolist(), final[0].tolist()
    ([2.0, 2.5, 3.0], [0.0, 0.0, 0.0])
    """
    keys, moved = np.ascontiguousarray(keys), np.ascontiguousarray(moved, dtype=np.float64)
    map_blocks(lambda rows: _place_nodes(nodes, final, node_of, chosen, int(first), keys, moved, float(h),
                                         rows.start, rows.stop), thread_blocks(len(keys)))
    return True


def place_faces(quads_out: np.ndarray, regions_out: np.ndarray, node_of: np.ndarray, quads: np.ndarray,
                regions: np.ndarray, renumber: np.ndarray) -> bool:
    """:func:`core.tile_merge.place_faces`; True.

    Examples
    --------
    >>> quads_out, regions_out = np.zeros((1, 4), np.int64), np.zeros((1, 2), np.int32)
    >>> place_faces(quads_out, regions_out, np.array([10, 11, 12, 13]), np.array([[0, 1, 3, 2]]),
    ...             np.array([[1, -1]], np.int32), np.array([0, 5], np.int32))
    True
    >>> quads_out.tolist(), regions_out.tolist()
    ([[10, 11, 13, 12]], [[5, -1]])
    """
    quads, regions = np.ascontiguousarray(quads), np.ascontiguousarray(regions)
    map_blocks(lambda rows: _place_faces(quads_out, regions_out, node_of, quads, regions, renumber,
                                         rows.start, rows.stop), thread_blocks(len(quads)))
    return True


def warm_up() -> int:
    """Compile for the arrays the tiles and the merge pass: int64 keys, node
    numbers and window quads, int32 lattice indices, piece quads and regions,
    float64 positions."""
    key = np.array([7 * 4 + 3, 4 * 4 + 1, 7 * 4 + 0], dtype=np.int64)
    chosen, node_of = number_nodes(key, np.argsort(key, kind="stable"), 4)
    assert chosen.tolist() == [1, 2] and node_of.tolist() == [1, 0, 1]
    nodes, final = np.zeros((2, 3)), np.zeros((2, 3))
    place_nodes(nodes, final, np.array([0, 1]), np.array([0, 1]), 0, np.ones((2, 3), np.int32), np.ones((2, 3)), 1.0)
    assert nodes.sum() == 6.0 and final.sum() == 6.0
    quads_out, regions_out = np.zeros((1, 4), np.int64), np.zeros((1, 2), np.int32)
    place_faces(quads_out, regions_out, np.arange(4, dtype=np.int64), np.array([[0, 1, 3, 2]], np.int32),
                np.array([[1, -1]], np.int32), np.array([0, 5], np.int32))
    assert quads_out.tolist() == [[0, 1, 3, 2]] and regions_out.tolist() == [[5, -1]]
    keys = np.array([[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], np.int32)
    keep, block = owned_faces(keys, np.array([[0, 1, 2, 3]], np.int64), np.array([[-1, -2]], np.int32),
                              np.zeros(1, np.int32), (0, 0, 1, 1), (1, 1))
    assert keep.tolist() == [True] and block.tolist() == [False]
    return 1


@compiled
def _owned(keys, quads, regions, renumber, i0, j0, i1, j1, nx, ny, start, stop, keep, keep_block):
    """Faces ``start:stop`` of :func:`owned_faces`: the centre's tests on
    the sum of the four corners (4 times the centre, exact integers)."""
    for f in range(start, stop):
        first, second = regions[f, 0], regions[f, 1]
        own = (first > 0 and renumber[first] > 0) or (second > 0 and renumber[second] > 0)
        keep_block[f] = own
        if own or first > 0 or second > 0:
            keep[f] = own
            continue
        x = np.int64(0)
        y = np.int64(0)
        for c in range(4):
            x += keys[quads[f, c], 0]
            y += keys[quads[f, c], 1]
        keep[f] = (x >= 4 * i0 and (x < 4 * i1 or i1 == nx)
                   and y >= 4 * j0 and (y < 4 * j1 or j1 == ny))


@compiled
def _number(copy_key, by_rank, ranks, chosen, node_of):
    """:func:`number_nodes` into ``chosen`` and ``node_of``; the number of nodes."""
    n = 0
    last = np.int64(-1)
    for m in range(len(by_rank)):
        copy = by_rank[m]
        key = copy_key[copy] // ranks  # keys are not negative
        if m == 0 or key != last:
            chosen[n] = copy
            n += 1
            last = key
        node_of[copy] = n - 1
    return n


@compiled
def _place_nodes(nodes, final, node_of, chosen, first, keys, moved, h, start, stop):
    """Rows ``start:stop`` of a piece's copies for :func:`place_nodes`."""
    for j in range(start, stop):
        node = node_of[j]
        if chosen[node] == first + j:
            for c in range(3):
                nodes[node, c] = np.float64(keys[j, c]) * h
                final[node, c] = moved[j, c]


@compiled
def _place_faces(quads_out, regions_out, node_of, quads, regions, renumber, start, stop):
    """Rows ``start:stop`` of a piece's faces for :func:`place_faces`."""
    for f in range(start, stop):
        for c in range(4):
            quads_out[f, c] = node_of[quads[f, c]]
        for s in range(2):
            region = regions[f, s]
            regions_out[f, s] = renumber[region] if region > 0 else region
