"""Compiled extraction of the faces between regions (numba, :mod:`core.jit`).

:meth:`core.surface.SurfaceModel.from_regions` lists every face between two
voxels of different regions, the domain padded with the outside region. numpy
pads the region volume (a copy of it), compares it with itself shifted along
each axis (a mask of the grid's size per axis), lists the differing pairs and
makes their corners through a chain of (F,) and (F, 4) temporaries: on the 85
M voxels of the 1 km synthetic city, 0.9-1.3 s. Here each axis is two passes
over the columns along z of the volume, one that counts the faces, one that
writes them, on all cores (slabs of x), without padding: 0.3-0.4 s for the
same faces, in the same order (numpy's C order over the pairs, axis after
axis), with the same corners and regions. Each pair of columns is counted
by a loop numba vectorises and written only if it holds a face: at 0.5 m
(680 M voxels, 19.4 M faces) 5.7 s voxel by voxel, 2.5-3.1 s so. The nodes the faces use are then
numbered (:func:`unique_nodes`) with a bit per lattice node instead of
numpy's tables of a boolean and a rank per node: 0.4-0.7 -> 0.1-0.3 s there.
The mesh files list each region's closed surface (:func:`sides_by_rank`)
through a counting sort of the faces' sides instead of a stable sort.
"""
from __future__ import annotations

import numpy as np

from .neighbours_kernel import compiled, inlined
from .parallel import map_blocks, thread_blocks


def faces_between(regions: np.ndarray, outside: int, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The faces between voxels of different regions of ``regions`` padded
    with ``outside``: their corners as flat lattice node numbers (M, 4),
    ``i + (nx + 1) (j + (ny + 1) k)``, and their back and front regions (M, 2).

    Parameters
    ----------
    regions : ndarray of int32 (nx, ny, nz)
    outside : int
        The region of the padding.
    corners : ndarray of int (3, 4, 3)
        Per axis, the lattice offsets of a face's four corners from its
        lowest one (:data:`core.surface._CORNERS`).

    Returns
    -------
    quads : ndarray of int64 (M, 4)
    pairs : ndarray of int32 (M, 2)

    Examples
    --------
    One voxel of region 1 in the outside region 0: its six faces.

    >>> from core.surface import _CORNERS
    >>> quads, pairs = faces_between(np.ones((1, 1, 1), np.int32), 0, _CORNERS)
    >>> len(quads), pairs.tolist()[:2], quads[0].tolist()
    (6, [[0, 1], [1, 0]], [0, 2, 6, 4])
    """
    regions = np.ascontiguousarray(regions, dtype=np.int32)
    nx, ny, nz = regions.shape
    nx1, ny1 = nx + 1, ny + 1
    offsets = np.array([[c[0] + nx1 * (c[1] + ny1 * c[2]) for c in corners[axis]] for axis in range(3)],
                       dtype=np.int64)
    # The pairs along an axis start at every padded voxel before its last layer along it.
    jobs = [(axis, rows) for axis in range(3) for rows in thread_blocks(nx + 2 - (axis == 0))]
    counts = map_blocks(lambda job: _faces(regions, outside, job[0], job[1].start, job[1].stop, offsets,
                                           _NONE, _NO_PAIRS, 0), jobs)
    first = np.cumsum([0] + counts)
    quads = np.empty((int(first[-1]), 4), dtype=np.int64)
    pairs = np.empty((int(first[-1]), 2), dtype=np.int32)
    map_blocks(lambda job: _faces(regions, outside, job[0][0], job[0][1].start, job[0][1].stop, offsets, quads,
                                  pairs, job[1]), list(zip(jobs, first[:-1].tolist())))
    return quads, pairs


def unique_nodes(flat: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`core.surface.unique_nodes`: the node numbers below ``size`` that
    ``flat`` uses, sorted, and the rank of each entry of ``flat`` among them
    (int32 where they fit, as numpy's).

    numpy marks the nodes in a table of ``size`` booleans and ranks them
    through a table of ``size`` integers (5 bytes per node of the lattice:
    the 87 M of the 1 km city, 0.4-0.7 s). Here a bit per node and the
    running count of each 64 of them, in the cache, give the rank of a node
    as the count before its word plus the bits before it in the word.

    Examples
    --------
    >>> used, inverse = unique_nodes(np.array([[7, 2], [2, 9]]), 10)
    >>> used.tolist(), inverse.tolist()
    ([2, 7, 9], [[1, 0], [0, 2]])
    """
    flat = np.asarray(flat)
    entries = np.ascontiguousarray(flat).ravel()
    words = np.zeros((int(size) + 63) // 64, dtype=np.uint64)
    _mark(entries, words)  # one thread: setting bits of a shared word is not atomic
    before = np.empty(len(words) + 1, dtype=np.int64)
    before[0] = 0
    np.cumsum(_bit_counts(words), out=before[1:])
    nodes = np.empty(int(before[-1]), dtype=np.int64)
    map_blocks(lambda rows: _list_nodes(words, before, rows.start, rows.stop, nodes), thread_blocks(len(words)))
    rank = np.empty(len(entries), dtype=np.int32 if len(nodes) <= np.iinfo(np.int32).max else np.int64)
    map_blocks(lambda rows: _rank(entries, words, before, rows.start, rows.stop, rank), thread_blocks(len(entries)))
    return nodes, rank.reshape(flat.shape)


#: Empty outputs: a call that only counts.
_NONE = np.empty((0, 4), dtype=np.int64)
_NO_PAIRS = np.empty((0, 2), dtype=np.int32)


def sides_by_rank(quads: np.ndarray, regions: np.ndarray, rank: np.ndarray,
                  n_ranks: int) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`core.surface.SurfaceModel.closed_surfaces` once each side's
    rank is known: the faces whose side has a rank (``rank`` of side
    ``2 f + s`` of face ``f``, -1 for none), rank by rank and in face order
    within one (a stable sort on the rank), each oriented out of the region
    of that side (reversed for side 1), and that region.

    A counting sort in two passes over the sides: numpy's stable sort, the
    gather of the rows and the flips of the inward ones took 0.6 s for the
    1 km synthetic city's 9.7 M triangles (19.4 M sides).

    Examples
    --------
    >>> quads = np.array([[0, 1, 2], [2, 1, 3]])
    >>> faces, region = sides_by_rank(quads, np.array([[5, -1], [-1, 5]], np.int32), np.array([0, 1, 1, 0]), 2)
    >>> faces.tolist(), region.tolist()
    ([[0, 1, 2], [3, 1, 2], [2, 1, 0], [2, 1, 3]], [5, 5, -1, -1])
    """
    quads, regions = np.ascontiguousarray(quads), np.ascontiguousarray(regions)
    rank = np.ascontiguousarray(rank, dtype=np.int64)
    counts = np.zeros(n_ranks + 1, np.int64)
    rank_starts(rank, counts)
    faces = np.empty((int(counts[-1]), quads.shape[1]), dtype=quads.dtype)
    region = np.empty(len(faces), np.int32)
    _place_sides(quads, regions, rank, counts, faces, region)
    return faces, region


def warm_up() -> int:
    """Compile for the region volumes the pipeline passes (int32)."""
    from .surface import _CORNERS

    quads, pairs = faces_between(np.ones((1, 1, 1), np.int32), 0, _CORNERS)
    assert len(quads) == 6 and pairs.tolist()[:2] == [[0, 1], [1, 0]], pairs
    for dtype in (np.int64, np.int32):
        used, inverse = unique_nodes(np.array([[7, 2], [2, 70]], dtype=dtype), 100)
        assert used.tolist() == [2, 7, 70] and inverse.tolist() == [[1, 0], [0, 2]], (used, inverse)
    for corners in (4, 3):  # quads, and the triangles the mesh files are written from
        regions = np.array([[5, -1], [-1, 5]], np.int32)
        faces, region = sides_by_rank(np.arange(2 * corners).reshape(2, corners), regions, np.array([0, 1, 1, 0]), 2)
        assert region.tolist() == [5, 5, -1, -1] and faces[1, 0] == 2 * corners - 1, (faces, region)
    return len(quads)


@compiled
def rank_starts(rank, counts):
    """Where each rank's rows start (``counts[r]``, zeros given) in a
    counting sort of ``rank`` (-1: none), and their number (``counts[-1]``);
    also :func:`core.grid_kernel.column_order`'s."""
    for e in range(len(rank)):
        if rank[e] >= 0:
            counts[rank[e]] += 1
    total = 0
    for r in range(len(counts) - 1):
        count = counts[r]
        counts[r] = total
        total += count
    counts[len(counts) - 1] = total


@compiled
def _faces(regions, outside, axis, start, stop, offsets, quads, pairs, at):
    """The faces along ``axis`` between the padded voxels whose first index
    is in ``start:stop`` and the next ones along the axis, in C order:
    counted, or written into ``quads`` and ``pairs`` from row ``at`` on.
    Returns how many.

    A row of padded voxels along z and the next row along the axis are two
    columns of the volume (or of the padding: ``outside``), or for z one
    column and itself one voxel up. Their pairs are counted by a loop that
    compares whole columns (vectorised), and written only in the rows that
    have a face: most pairs are two voxels of one region, and across x and
    y most rows have none."""
    nx, ny, nz = regions.shape
    write = len(quads) > 0
    n = 0
    sy = ny + 2 - (axis == 1)
    for i in range(start, stop):
        for j in range(sy):
            # Padded voxel (i, j, k) and the next along the axis: columns of
            # the volume (or of the padding) one beside the other.
            ib, jb = i - 1, j - 1
            i_f, j_f = ib + (axis == 0), jb + (axis == 1)
            back_in = 0 <= ib < nx and 0 <= jb < ny
            front_in = 0 <= i_f < nx and 0 <= j_f < ny
            if not back_in and not front_in:
                continue  # padding beside padding
            back = regions[ib, jb] if back_in else regions[i_f, j_f]
            front = regions[i_f, j_f] if front_in else back
            count = _row_faces(back, front, outside, axis, back_in, front_in)
            if write and count:
                _write_row(back, front, outside, axis, back_in, front_in, i_f, j_f, nx + 1, ny + 1,
                           offsets, quads, pairs, at + n)
            n += count
    return n


@inlined
def _row_faces(back, front, outside, axis, back_in, front_in):
    """The faces between a row and the next along ``axis`` (see :func:`_faces`)."""
    nz = len(back)
    count = 0
    if axis == 2:  # the column and itself one up, the padding below and above it
        count = (back[0] != outside) + (back[nz - 1] != outside)
        for k in range(nz - 1):
            count += back[k] != back[k + 1]
    elif back_in and front_in:
        for k in range(nz):
            count += back[k] != front[k]
    else:  # one column beside the padding (back holds it)
        for k in range(nz):
            count += back[k] != outside
    return count


@inlined
def _write_row(back, front, outside, axis, back_in, front_in, i_f, j_f, nx1, ny1, offsets, quads, pairs, row):
    """The faces :func:`_row_faces` counts, written from ``row`` on in the
    order of their padded voxels along z."""
    nz = len(back)
    for k in range(nz + 1 if axis == 2 else nz):
        # The voxels behind and in front of the face (the front one at height k).
        if axis == 2:
            behind = back[k - 1] if k > 0 else outside
            ahead = back[k] if k < nz else outside
        else:
            behind = back[k] if back_in else outside
            ahead = front[k] if front_in else outside
        if behind == ahead:
            continue
        # The face's lowest lattice node: (padded voxel - 1) + one step along the axis.
        base = i_f + nx1 * (j_f + ny1 * k)
        for c in range(4):
            quads[row, c] = base + offsets[axis, c]
        pairs[row, 0], pairs[row, 1] = behind, ahead
        row += 1


@compiled
def _mark(entries, words):
    """Set the bit of every node in ``entries``."""
    for e in range(len(entries)):
        node = entries[e]
        words[node >> 6] |= np.uint64(1) << np.uint64(node & 63)


@compiled
def bit_count(word):
    """The number of bits set in a 64-bit word (the SWAR popcount)."""
    word = word - ((word >> np.uint64(1)) & np.uint64(0x5555555555555555))
    word = (word & np.uint64(0x3333333333333333)) + ((word >> np.uint64(2)) & np.uint64(0x3333333333333333))
    word = (word + (word >> np.uint64(4))) & np.uint64(0x0F0F0F0F0F0F0F0F)
    return np.int64((word * np.uint64(0x0101010101010101)) >> np.uint64(56))


@compiled
def _bit_counts(words):
    """Bits set in each word."""
    out = np.empty(len(words), np.int64)
    for w in range(len(words)):
        out[w] = bit_count(words[w])
    return out


@compiled
def _list_nodes(words, before, start, stop, nodes):
    """The nodes of words ``start:stop``, in order, from ``nodes[before[start]]`` on."""
    at = before[start]
    for w in range(start, stop):
        word = words[w]
        bit = 0
        while word:
            if word & np.uint64(1):
                nodes[at] = 64 * w + bit
                at += 1
            word >>= np.uint64(1)
            bit += 1


@compiled
def _rank(entries, words, before, start, stop, rank):
    """The rank among the marked nodes of ``entries[start:stop]``."""
    for e in range(start, stop):
        node = entries[e]
        w = node >> 6
        below = (np.uint64(1) << np.uint64(node & 63)) - np.uint64(1)
        rank[e] = before[w] + bit_count(words[w] & below)


@compiled
def _place_sides(quads, regions, rank, start, faces, region):
    """Each ranked side's face, in side order, to the next row of its rank
    (``start``, advanced), reversed for side 1; its region beside it."""
    corners = quads.shape[1]
    for e in range(len(rank)):
        r = rank[e]
        if r < 0:
            continue
        f, side = e >> 1, e & 1
        row = start[r]
        start[r] = row + 1
        for c in range(corners):
            faces[row, c] = quads[f, corners - 1 - c] if side else quads[f, c]
        region[row] = regions[f, side]
