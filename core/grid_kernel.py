"""Compiled binning of points into the voxel grid (numba, :mod:`core.jit`).

The issue that asked for speed sets the voxel binning at 60 M points per
second or more, 25 times Open3D's voxel grid. numpy's binning
(:meth:`core.grid.VoxelGrid.occupancy`) makes each point's voxel number in
passes over chunks of points, scatters a byte per point into a grid-sized
mask and lists the mask's set voxels: 0.08-0.10 s for the 3.3 M building
points of the 1 km synthetic city, plus 0.03 s for the list, of which the
first touch of the 85 MB mask's pages is much. Here each thread marks its
points in a bitmap of its own (one bit per voxel: 11 MB there), the voxel
numbers made a chunk of points at a time in a loop the compiler turns into
vector instructions. A summary of a bit per word tells which words a thread
wrote: the bitmaps are never zeroed, and the listing, on all cores, reads
only the written words (7 % of them there): 0.014-0.017 s (190-230 M
points/s) where zeroed bitmaps read whole took 0.019-0.021 s in the same
hour (0.025-0.035 s on other days: this machine's memory speed varies). Column numbers
(:meth:`core.grid.VoxelGrid.column_of`, 0.1-0.2 s for the 7.2 M ground
points of that city in numpy) take one such pass: 0.007-0.015 s, and so
do the tiled run's cells along x and along y (:func:`axis_cells`) and
the columns of its world points for the ground level (:func:`local_columns`).

Every number is numpy's: the same floor of the same quotient, clipped the
same way; the voxel number is an integer below 2**53, which numpy's float
product and the integer one here give exactly.

The tiled run (:mod:`core.tiles`) orders all the points by their column
along x: a counting sort (:func:`column_order`) writes that order in one
pass, where numpy's stable argsort of the 16-bit columns, a radix sort,
and its int64 result took 0.5-1.2 s for the 2 km city's 35 M ground points.
"""
from __future__ import annotations

import numpy as np

from .neighbours_kernel import compiled
from .parallel import counted_then_listed, map_blocks, row_blocks, thread_blocks, thread_count
from .surface_kernel import bit_count, rank_starts

#: Fewest points per thread of the binning: a bitmap's fresh pages and a
#: thread's start cost more than fewer points take.
_THREAD_POINTS = 1 << 19
#: Points whose numbers are made at a time (rows of a few kB, in the cache).
_CHUNK = 512
#: The place of a word's single set bit: a de Bruijn sequence times the bit
#: has a distinct top six bits for each place (a table of them below).
_DE_BRUIJN = np.uint64(0x03F79D71B4CB0A89)
_BIT_OF = np.empty(64, dtype=np.int64)
_BIT_OF[[int(((1 << b) * 0x03F79D71B4CB0A89) % 2**64) >> 58 for b in range(64)]] = np.arange(64)


def occupied_cells(points: np.ndarray, origin: np.ndarray, voxel_size: float,
                   shape: tuple[int, int, int]) -> np.ndarray:
    """:meth:`core.grid.VoxelGrid.occupied_cells`: the distinct cells
    ``(i, j, k)`` holding a point, by voxel number.

    Examples
    --------
    >>> occupied_cells(np.array([[0.5, 2.5, 1.2], [3.5, 0.5, 0.5], [0.1, 2.9, 1.0]]), np.zeros(3),
    ...                1.0, (4, 3, 2)).tolist()
    [[3, 0, 0], [0, 2, 1]]
    """
    points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    origin = np.ascontiguousarray(origin, dtype=np.float64)
    nx, ny, nz = (int(n) for n in shape)
    words = (nx * ny * nz + 63) // 64
    # A bitmap per thread: two threads setting bits of one word would lose
    # some. Each has a summary, a bit per word it has written: the bitmaps
    # are neither zeroed nor read where their summary is clear, and most of
    # their pages are never touched (the 1 km city's building points write
    # 7 % of the 1.3 M words; 6.5 % of a page's 512 words on average).
    parts = row_blocks(len(points), max(-(-len(points) // thread_count()), _THREAD_POINTS))
    bits = np.empty((max(len(parts), 1), words), dtype=np.uint64)
    written = np.zeros((len(bits), (words + 63) // 64), dtype=np.uint64)

    def mark(part: int) -> None:
        rows = parts[part]
        _mark(points, rows.start, rows.stop, origin, float(voxel_size), nx, ny, nz, bits[part], written[part])

    map_blocks(mark, range(len(parts)))
    # As many cells as points at most, and a summary word per 4096 voxels:
    # few points are listed on this thread, where the pool's handoffs cost more.
    summaries = thread_blocks(written.shape[1]) if len(parts) > 1 else [slice(0, written.shape[1])]
    return counted_then_listed(lambda summary, out, at: _listed_into(bits, written, summary.start, summary.stop,
                                                                     nx, ny, out, at), summaries).reshape(-1, 3)


def column_of(points: np.ndarray, origin: np.ndarray, voxel_size: float, shape: tuple[int, int, int]) -> np.ndarray:
    """:meth:`core.grid.VoxelGrid.column_of`: the column number ``i * ny + j`` of each point.

    Examples
    --------
    >>> column_of(np.array([[0.5, 2.5, 1.2], [3.5, 0.5, 9.0], [-1.0, 9.0, 0.0]]), np.zeros(3),
    ...           1.0, (4, 3, 2)).tolist()
    [2, 9, 2]
    """
    points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    origin = np.ascontiguousarray(origin, dtype=np.float64)
    column = np.empty(len(points), dtype=np.int64)
    nx, ny = int(shape[0]), int(shape[1])

    def fill(rows: slice) -> None:
        _columns(points, rows.start, rows.stop, origin, float(voxel_size), nx, ny, column)

    map_blocks(fill, thread_blocks(len(points)))
    return column


def local_columns(points: np.ndarray, offset: np.ndarray, origin: np.ndarray, voxel_size: float,
                  shape: tuple[int, int, int]) -> tuple[np.ndarray, np.ndarray]:
    """:func:`core.ground._local_columns`: the column number and local height
    of points given in world coordinates (``points - offset`` the local ones).

    Examples
    --------
    >>> column, height = local_columns(np.array([[100.5, 202.5, 11.0], [102.5, 200.5, 12.5]]),
    ...                                np.array([100.0, 200.0, 10.0]), np.zeros(3), 1.0, (3, 3, 5))
    >>> column.tolist(), height.tolist()
    ([2, 6], [1.0, 2.5])
    """
    points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    offset = np.ascontiguousarray(offset, dtype=np.float64)
    origin = np.ascontiguousarray(origin, dtype=np.float64)
    column = np.empty(len(points), dtype=np.int64)
    height = np.empty(len(points), dtype=np.float64)
    nx, ny = int(shape[0]), int(shape[1])
    map_blocks(lambda rows: _local_columns(points, rows.start, rows.stop, offset, origin, float(voxel_size),
                                           nx, ny, column, height), thread_blocks(len(points)))
    return column, height


def axis_cells(x: np.ndarray, lower: float, h: float, n: int, out: np.ndarray) -> np.ndarray:
    """:func:`core.tiles._column` into ``out``: the cell of each coordinate
    ``x`` along one axis of ``n`` cells of side ``h`` from ``lower``.

    Examples
    --------
    >>> axis_cells(np.array([0.5, 2.5, -1.0, 9.0]), 0.0, 1.0, 3, np.empty(4, np.uint16)).tolist()
    [0, 2, 0, 2]
    """
    map_blocks(lambda rows: _axis_cells(x, float(lower), float(h), n - 1.0, rows.start, rows.stop, out),
               thread_blocks(len(x)))
    return out


def column_order(column: np.ndarray, n: int, dtype: type) -> np.ndarray:
    """``np.argsort(column, kind="stable").astype(dtype)`` for columns ``0..n-1``.

    Examples
    --------
    >>> column_order(np.array([2, 0, 2, 1, 0], np.uint16), 3, np.int32).tolist()
    [1, 4, 3, 0, 2]
    """
    order = np.empty(len(column), dtype=dtype)
    _counting_order(np.ascontiguousarray(column), n, order)
    return order


def warm_up() -> int:
    """Compile for the types :mod:`core.grid` and :mod:`core.tiles` pass."""
    cells = occupied_cells(np.array([[0.5, 2.5, 1.2], [3.5, 0.5, 0.5], [0.1, 2.9, 1.0]]), np.zeros(3),
                           1.0, (4, 3, 2))
    assert cells.tolist() == [[3, 0, 0], [0, 2, 1]], cells
    column = column_of(np.array([[0.5, 2.5, 1.2], [-1.0, 9.0, 0.0]]), np.zeros(3), 1.0, (4, 3, 2))
    assert column.tolist() == [2, 2], column
    column, height = local_columns(np.array([[100.5, 202.5, 11.0]]), np.array([100.0, 200.0, 10.0]), np.zeros(3),
                                   1.0, (3, 3, 5))
    assert column.tolist() == [2] and height.tolist() == [1.0]
    xyz = np.array([[0.5, 2.5, 1.2], [-1.0, 9.0, 0.0]])
    for dtype in (np.uint16, np.int32):
        assert axis_cells(xyz[:, 1], 0.0, 1.0, 3, np.empty(2, dtype)).tolist() == [2, 2]
    for keys in (np.array([1, 0, 1], np.uint16), np.array([1, 0, 1], np.int32)):
        for dtype in (np.int32, np.int64):
            assert column_order(keys, 2, dtype).tolist() == [1, 0, 2]
    return 1


@compiled
def _cell(x, low, voxel_size, top):
    """One coordinate's cell as :meth:`core.grid.VoxelGrid.cell_of` makes it:
    the floor of ``(x - low) / voxel_size``, clipped to ``0..top``."""
    return int(min(max(np.floor((x - low) / voxel_size), 0.0), top))


@compiled
def _axis_cells(x, low, voxel_size, top, start, stop, out):
    """Rows ``start:stop`` of :func:`axis_cells`."""
    for q in range(start, stop):
        out[q] = _cell(x[q], low, voxel_size, top)


@compiled
def _gathered(points, first, count, x, y, z):
    """Rows ``first:first + count`` of ``points`` (N, 3) into the rows ``x``, ``y``, ``z``."""
    for q in range(count):
        x[q], y[q], z[q] = points[first + q, 0], points[first + q, 1], points[first + q, 2]


@compiled
def _voxel_numbers(x, y, z, count, origin, voxel_size, nx, ny, nz, number):
    """The voxel numbers of the first ``count`` points of rows ``x``, ``y``, ``z``.

    A loop of its own over contiguous rows, which the compiler turns into
    vector instructions: over the rows of an (N, 3) table, or with the bits
    set in the same loop, it does not (0.04 -> 0.02 s for 3.3 M points)."""
    for q in range(count):
        i = _cell(x[q], origin[0], voxel_size, nx - 1.0)
        j = _cell(y[q], origin[1], voxel_size, ny - 1.0)
        k = _cell(z[q], origin[2], voxel_size, nz - 1.0)
        number[q] = i + nx * (j + ny * k)


@compiled
def _mark(points, start, stop, origin, voxel_size, nx, ny, nz, bits, written):
    """Set the bit of the voxel of every point of rows ``start:stop``, ``_CHUNK`` points at a time.

    A word of ``bits`` whose bit in ``written`` is clear holds anything: it
    is written whole the first time, and only then marked written."""
    x, y, z = np.empty(_CHUNK), np.empty(_CHUNK), np.empty(_CHUNK)
    number = np.empty(_CHUNK, np.int64)
    for first in range(start, stop, _CHUNK):
        count = min(_CHUNK, stop - first)
        _gathered(points, first, count, x, y, z)
        _voxel_numbers(x, y, z, count, origin, voxel_size, nx, ny, nz, number)
        for q in range(count):
            word = number[q] >> 6
            bit = np.uint64(1) << np.uint64(number[q] & 63)
            flag = np.uint64(1) << np.uint64(word & 63)
            if written[word >> 6] & flag:
                bits[word] |= bit
            else:
                bits[word] = bit
                written[word >> 6] |= flag


@compiled
def _place(low):
    """The place (0-63) of the single bit set in ``low``."""
    return _BIT_OF[(low * _DE_BRUIJN) >> np.uint64(58)]


@compiled
def _listed_into(bits, written, first, stop, nx, ny, out, at):
    """The cells of the voxels set in any thread's bitmap, for the summary
    words ``first:stop``, as :func:`core.parallel.counted_then_listed` runs
    them: with ``out`` empty, merge the threads' written words into row 0
    (and their summaries into ``written[0]``) and count the cells; else
    write the cells' ``i, j, k`` into ``out`` from ``at`` on, by voxel
    number. Returns three entries per cell."""
    if len(out) == 0:
        count = 0
        for s in range(first, stop):
            union = written[0, s]
            for t in range(1, written.shape[0]):
                union |= written[t, s]
            rest = union
            while rest:
                low = rest & (~rest + np.uint64(1))
                w = 64 * s + _place(low)
                word = np.uint64(0)
                for t in range(written.shape[0]):
                    if written[t, s] & low:
                        word |= bits[t, w]
                bits[0, w] = word
                count += bit_count(word)
                rest ^= low
            written[0, s] = union
        return 3 * count
    nxy = nx * ny
    i = j = k = 0
    last = -nxy  # no cell yet: the first one is divided out
    row = at
    for s in range(first, stop):
        rest = written[0, s]
        while rest:
            low = rest & (~rest + np.uint64(1))
            w = 64 * s + _place(low)
            word = bits[0, w]
            while word:
                bit = word & (~word + np.uint64(1))
                number = 64 * w + _place(bit)
                # Set voxels come in runs along x: the next one of a row is a
                # step along it, with no division (2-3 per cell otherwise).
                if number - last < nx - i:
                    i += number - last
                else:
                    k = number // nxy
                    j = (number - k * nxy) // nx
                    i = number - k * nxy - j * nx
                last = number
                out[row], out[row + 1], out[row + 2] = i, j, k
                row += 3
                word ^= bit
            rest ^= low
    return row - at


@compiled
def _columns(points, start, stop, origin, voxel_size, nx, ny, column):
    """Rows ``start:stop`` of :func:`column_of`, ``_CHUNK`` points at a time
    (vector instructions, as :func:`_voxel_numbers`)."""
    x, y, z = np.empty(_CHUNK), np.empty(_CHUNK), np.empty(_CHUNK)
    for first in range(start, stop, _CHUNK):
        count = min(_CHUNK, stop - first)
        _gathered(points, first, count, x, y, z)
        for q in range(count):
            column[first + q] = (_cell(x[q], origin[0], voxel_size, nx - 1.0) * ny
                                 + _cell(y[q], origin[1], voxel_size, ny - 1.0))


@compiled
def _local_columns(points, start, stop, offset, origin, voxel_size, nx, ny, column, height):
    """Rows ``start:stop`` of :func:`local_columns`: the local coordinates
    rounded as numpy's ``points - offset``, then :func:`_columns`' cells."""
    for q in range(start, stop):
        x = points[q, 0] - offset[0]
        y = points[q, 1] - offset[1]
        column[q] = _cell(x, origin[0], voxel_size, nx - 1.0) * ny + _cell(y, origin[1], voxel_size, ny - 1.0)
        height[q] = points[q, 2] - offset[2]


@compiled
def _counting_order(column, n, order):
    """:func:`column_order` into ``order``: each point after the earlier
    points of its column, the columns in turn."""
    start = np.zeros(n + 1, np.int64)
    rank_starts(column, start)
    for p in range(len(column)):
        c = column[p]
        order[start[c]] = p
        start[c] += 1
