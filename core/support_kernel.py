"""Compiled support test of the elimination (numba, :mod:`core.jit`).

Whether a data point supports each building/air face (:mod:`core.eliminate`):
a point within ``support`` voxel sizes of the face, or for a wall or a top
of an airborne scan, above it within that distance horizontally. numpy asks a
KD-tree for the nearest points around each face and tests them: about 2 s
of the 1 km synthetic city, most of it searches for points it then throws
away. Here each face walks the columns of the point index
(:class:`core.neighbours_kernel.ColumnIndex`) around it and stops at the
first point that supports it.

The faces to test are listed here too: every building/air face for the
first pass (:func:`boundary_faces`), those the last removals exposed for
the next (:func:`exposed_faces`).

The answer is the numpy test's (:func:`core.eliminate.supported_near` and
:func:`core.eliminate.supported_above`), face by face: a point is in the
searched ball as the KD-tree's bound decides (squared distance summed x, y,
z, strictly below the bound's square), and in the face's zone by the same
operations in the same order.
"""
from __future__ import annotations

import numpy as np

from .neighbours_kernel import (BOX, ColumnIndex, column_in_turn, column_range, compiled, inlined, own_column_first,
                                rising_from)
from .parallel import map_blocks, thread_blocks

#: Faces per block of work on a core.
_BLOCK = 1 << 14
#: Voxels of the labels scanned per block of work on a core.
_SLAB_VOXELS = 1 << 22


def supported_near(index: ColumnIndex, centre: np.ndarray, axis: np.ndarray, h: float, support: float,
                   r_outer: float) -> np.ndarray:
    """Whether a point of ``index`` lies within ``support * h`` of each
    square face (centre (F, 3), normal along ``axis`` (F,), side ``h``),
    among the points strictly within ``r_outer`` of its centre.

    Examples
    --------
    A face of a unit voxel at x = 1 (normal along x), a point 0.5 in front of
    it and one 0.7 in front:

    >>> index = ColumnIndex(np.array([[1.5, 0.5, 0.5], [1.7, 3.0, 0.5]]), 1.5)
    >>> centre = np.array([[1.0, 0.5, 0.5], [1.0, 3.0, 0.5]])
    >>> supported_near(index, centre, np.array([0, 0]), 1.0, 0.6, 0.93).tolist()
    [True, False]
    """
    return _on_blocks(_near, index, centre, axis, h, support, r_outer)


def supported_above(index: ColumnIndex, centre: np.ndarray, axis: np.ndarray, h: float, support: float,
                    r_outer: float) -> np.ndarray:
    """Whether a point of ``index`` no lower than half a voxel below each
    wall or top face's centre lies within ``support * h`` of the face
    horizontally (:func:`core.eliminate.supported_above`), among the points
    strictly within ``r_outer`` of the centre in plan.

    Examples
    --------
    A roof edge 3 m above a wall face at x = 1, and a face with nothing above:

    >>> index = ColumnIndex(np.array([[0.9, 0.5, 3.5]]), 1.5)
    >>> centre = np.array([[1.0, 0.5, 0.5], [1.0, 5.5, 0.5]])
    >>> supported_above(index, centre, np.array([0, 0]), 1.0, 0.6, 0.79).tolist()
    [True, False]
    """
    return _on_blocks(_above, index, centre, axis, h, support, r_outer)


def boundary_faces(flat: np.ndarray, shape: np.ndarray, building: int,
                   air: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`core.eliminate.boundary_faces`: the faces between a ``building``
    cell and an ``air`` cell of the C-ordered labels ``flat`` of ``shape``,
    as the building cell (F, 3), the axis (F,) and the side of the air (F,),
    grouped by the six directions (+x, -x, +y, -y, +z, -z, as
    ``core.eliminate._SIX``), each direction's in the cells' order.

    The labels are scanned, slabs of x rows on all cores: a first scan
    counts the faces per slab and direction, a second writes them. The list
    of every building cell numpy makes first (``np.flatnonzero``), and its
    faces found from it, took 3.0-3.5 s and 950 MB on the 1 km synthetic
    city at 0.5 m (680 M voxels, 31.5 M building cells, 6.5 M faces); the
    scans cell by cell 1.3-1.8 s, column by column (:func:`_slab_faces`) 0.82-1.06 s.

    Examples
    --------
    >>> flat = np.array([3, 2, 2, 1], np.uint8)  # air, two building cells, ground along z
    >>> ijk, axis, sign = boundary_faces(flat, np.array([1, 1, 4]), 2, 3)
    >>> ijk.tolist(), axis.tolist(), sign.tolist()
    ([[0, 0, 1]], [2], [-1])
    """
    flat = np.ascontiguousarray(flat)
    nx, ny, nz = (int(v) for v in shape)
    # Slabs of about _SLAB_VOXELS voxels: many per thread, so that one done first takes the next.
    slabs = thread_blocks(nx, max(1, _SLAB_VOXELS // max(ny * nz, 1)))
    # Counted (no row to write from, no table to write into), then written.
    nowhere, no_tables = np.zeros(0, np.int64), _face_tables(np.zeros((0, 6), np.int64))[:3]
    counts = np.array(map_blocks(lambda rows: _slab_faces(flat, nx, ny, nz, building, air, rows.start, rows.stop,
                                                          nowhere, *no_tables), slabs),
                      dtype=np.int64).reshape(len(slabs), 6)
    ijk, axis, sign, first = _face_tables(counts)
    map_blocks(lambda b: _slab_faces(flat, nx, ny, nz, building, air, slabs[b].start, slabs[b].stop,
                                     first[:, b].copy(), ijk, axis, sign), range(len(slabs)))
    return ijk, axis, sign


def exposed_faces(flat: np.ndarray, gone: np.ndarray, shape: np.ndarray,
                  building: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`core.eliminate.exposed_faces`: the faces of the ``building``
    cells next to the cells ``gone`` (flat indices into the C-ordered labels
    ``flat`` of ``shape``, just turned to air), towards them: as the
    building cell (F, 3), the axis (F,) and the side of the air (F,),
    grouped by the direction from the gone cell to the building one (+x,
    -x, ... as ``core.eliminate._SIX``), each direction's in ``gone``'s
    order. One pass marks each gone cell's building neighbours (a bit per
    direction) and counts them, then the faces are written, on all cores.

    Examples
    --------
    >>> flat = np.array([3, 3, 2, 1], np.uint8)  # air, air (just gone), building, ground along z
    >>> ijk, axis, sign = exposed_faces(flat, np.array([1]), np.array([1, 1, 4]), 2)
    >>> ijk.tolist(), axis.tolist(), sign.tolist()
    ([[0, 0, 2]], [2], [-1])
    """
    flat = np.ascontiguousarray(flat)
    gone = np.ascontiguousarray(gone, dtype=np.int64)
    shape = np.asarray(shape, dtype=np.int64)
    parts = thread_blocks(len(gone), _BLOCK)
    # A bit per direction and gone cell (a building cell that way), and the count per block and direction.
    facing = np.empty(len(gone), dtype=np.uint8)
    counts = np.array(map_blocks(lambda rows: _facing(flat, gone, shape, building, rows.start, rows.stop, facing),
                                 parts), dtype=np.int64).reshape(len(parts), 6)
    ijk, axis, sign, first = _face_tables(counts)
    jobs = [(step, b) for step in range(6) for b in range(len(parts))]
    map_blocks(lambda job: _write_faces(gone, shape, facing, job[0], parts[job[1]].start, parts[job[1]].stop,
                                        ijk, axis, sign, int(first[job[0], job[1]])), jobs)
    return ijk, axis, sign


def _face_tables(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The faces' tables for ``counts`` (blocks x 6 directions) and the row
    each (direction, block) starts at: direction by direction, block by block."""
    first = np.concatenate([[0], np.cumsum(counts.T.ravel())])
    n = int(first[-1])
    ijk = np.empty((n, 3), dtype=np.int64)
    axis = np.empty(n, dtype=np.int64)
    sign = np.empty(n, dtype=np.int64)
    return ijk, axis, sign, first[:-1].reshape(6, len(counts))


def _on_blocks(kernel, index: ColumnIndex, centre: np.ndarray, axis: np.ndarray, h: float, support: float,
               r_outer: float) -> np.ndarray:
    """``kernel`` over blocks of faces, on the pool's threads (each face is tested alone)."""
    centre = np.ascontiguousarray(centre, dtype=np.float64).reshape(-1, 3)
    axis = np.ascontiguousarray(axis, dtype=np.int64)
    out = np.zeros(len(centre), dtype=np.bool_)
    r_inner = support * h

    def fill(rows: slice) -> None:
        kernel(centre, axis, rows.start, rows.stop, 0.5 * h, r_inner * r_inner, float(r_outer),
               index.x0, index.y0, index.cell, index.nx, index.ny, index.start, index.points, out)

    if len(centre):
        map_blocks(fill, thread_blocks(len(centre), _BLOCK))
    return out


def warm_up() -> int:
    """Compile for the types the elimination passes."""
    index = ColumnIndex(np.array([[1.5, 0.5, 0.5], [0.9, 3.0, 2.5]]), 1.5)
    centre = np.array([[1.0, 0.5, 0.5], [1.0, 3.0, 0.5]])
    axis = np.array([0, 0])
    assert supported_near(index, centre, axis, 1.0, 0.6, 0.93).tolist() == [True, False]
    assert supported_above(index, centre, axis, 1.0, 0.6, 0.79).tolist() == [True, True]
    ijk, axis, sign = boundary_faces(np.array([3, 2, 2, 1], np.uint8), np.array([1, 1, 4]), 2, 3)
    assert ijk.tolist() == [[0, 0, 1]] and axis.tolist() == [2] and sign.tolist() == [-1], (ijk, axis, sign)
    ijk, axis, sign = exposed_faces(np.array([3, 3, 2, 1], np.uint8), np.array([1]), np.array([1, 1, 4]), 2)
    assert ijk.tolist() == [[0, 0, 2]] and axis.tolist() == [2] and sign.tolist() == [-1], (ijk, axis, sign)
    return 1


@compiled
def _near(centre, axis, lo, hi, half, r_inner2, r_outer, x0, y0, cell, nx, ny, start, points, out):
    """Faces ``lo:hi`` of :func:`supported_near` into ``out``."""
    r_outer2 = r_outer * r_outer
    box = r_outer * BOX
    for f in range(lo, hi):
        cx, cy, cz, a = centre[f, 0], centre[f, 1], centre[f, 2], axis[f]
        ix0, ix1, iy0, iy1 = column_range(cx, cy, box, x0, y0, cell, nx, ny)
        found = False
        own, width, count = own_column_first(cx, cy, x0, y0, cell, ix0, ix1, iy0, iy1)
        for visit in range(count):
            ix, iy = column_in_turn(visit, own, width, ix0, iy0)
            t, end = rising_from(start, points, ix + nx * iy, cz - box)
            while t < end and points[2, t] <= cz + box and not found:
                dx, dy, dz = points[0, t] - cx, points[1, t] - cy, points[2, t] - cz
                t += 1
                if (dx * dx + dy * dy) + dz * dz >= r_outer2:
                    continue  # outside the ball, as the KD-tree's bound decides
                # Across the face the distance counts, along it what lies past its edge.
                gx, gy, gz = abs(dx), abs(dy), abs(dz)
                tx = gx if a == 0 else max(gx - half, 0.0)
                ty = gy if a == 1 else max(gy - half, 0.0)
                tz = gz if a == 2 else max(gz - half, 0.0)
                found = (tx * tx + ty * ty) + tz * tz <= r_inner2
            if found:
                break
        out[f] = found


@compiled
def _above(centre, axis, lo, hi, half, r_inner2, r_outer, x0, y0, cell, nx, ny, start, points, out):
    """Faces ``lo:hi`` of :func:`supported_above` into ``out``."""
    r_outer2 = r_outer * r_outer
    box = r_outer * BOX
    for f in range(lo, hi):
        cx, cy, a = centre[f, 0], centre[f, 1], axis[f]
        ix0, ix1, iy0, iy1 = column_range(cx, cy, box, x0, y0, cell, nx, ny)
        found = False
        own, width, count = own_column_first(cx, cy, x0, y0, cell, ix0, ix1, iy0, iy1)
        for visit in range(count):
            ix, iy = column_in_turn(visit, own, width, ix0, iy0)
            # A column's points by height: those from half a voxel below the centre up.
            t, end = rising_from(start, points, ix + nx * iy, centre[f, 2] - half)
            while t < end and not found:
                dx, dy = points[0, t] - cx, points[1, t] - cy
                t += 1
                if dx * dx + dy * dy >= r_outer2:
                    continue
                # A wall: across it, and along it past its edge; a top: past its edges, both ways.
                if a == 2:
                    across, along = max(abs(dx) - half, 0.0), max(abs(dy) - half, 0.0)
                else:
                    across = abs(dx) if a == 0 else abs(dy)
                    along = max((abs(dy) if a == 0 else abs(dx)) - half, 0.0)
                found = across * across + along * along <= r_inner2
            if found:
                break
        out[f] = found


@compiled
def _slab_faces(flat, nx, ny, nz, building, air, i0, i1, at, ijk, axis, sign):
    """The faces of :func:`boundary_faces` in the slabs ``i0:i1``: counted
    per direction, and written if ``at`` is not empty, those towards
    direction ``step`` from row ``at[step]`` on. Returns the counts.

    A column's faces towards a direction are those of its cells and their
    neighbours that way, a column beside it (or itself shifted along z):
    counted a column at a time by loops numba vectorises, and written where
    there are any. Most columns hold no building cell, or no face along x
    and y."""
    write = len(at) > 0
    count = np.zeros(6, np.int64)
    for i in range(i0, i1):
        for j in range(ny):
            base = (i * ny + j) * nz
            if _pairs(flat[base:base + nz], flat[base:base + nz], building, building) == 0:
                continue  # not a building cell in the column
            for step in range(6):
                cells, beyond, first = _column_and_beyond(flat, i, j, nx, ny, nz, step)
                found = _pairs(cells, beyond, building, air)
                if found == 0:
                    continue
                count[step] += found
                if write:
                    n = at[step]
                    for k in range(len(cells)):
                        if cells[k] == building and beyond[k] == air:
                            ijk[n, 0], ijk[n, 1], ijk[n, 2] = i, j, first + k
                            axis[n], sign[n] = step // 2, 1 - 2 * (step % 2)
                            n += 1
                    at[step] = n
    return count


@inlined
def _pairs(cells, beyond, value, other):
    """How many ``k`` have ``cells[k] == value`` and ``beyond[k] == other``."""
    found = 0
    for k in range(len(cells)):
        found += (cells[k] == value) & (beyond[k] == other)
    return found


@inlined
def _column_and_beyond(flat, i, j, nx, ny, nz, step):
    """The cells of column ``(i, j)`` that have a neighbour towards direction
    ``step`` (+x, -x, +y, -y, +z, -z) inside the grid, those neighbours, and
    the height of the first cell."""
    base = (i * ny + j) * nz
    if step == 4:
        return flat[base:base + nz - 1], flat[base + 1:base + nz], 0
    if step == 5:
        return flat[base + 1:base + nz], flat[base:base + nz - 1], 1
    if step == 0:
        inside, other = i + 1 < nx, base + ny * nz
    elif step == 1:
        inside, other = i > 0, base - ny * nz
    elif step == 2:
        inside, other = j + 1 < ny, base + nz
    else:
        inside, other = j > 0, base - nz
    if not inside:
        return flat[base:base], flat[base:base], 0
    return flat[base:base + nz], flat[other:other + nz], 0


@compiled
def _facing(flat, cells, shape, value, start, stop, facing):
    """For ``cells[start:stop]``, bit ``step`` of ``facing`` set where the
    neighbour towards direction ``step`` (+x, -x, +y, -y, +z, -z, as
    ``core.eliminate._SIX``) is inside the grid and holds ``value``; returns
    the count per direction."""
    nx, ny, nz = shape[0], shape[1], shape[2]
    count = np.zeros(6, np.int64)
    for c in range(start, stop):
        cell = cells[c]
        i, rest = cell // (ny * nz), cell % (ny * nz)
        j, k = rest // nz, rest % nz
        bits = 0
        if i + 1 < nx and flat[cell + ny * nz] == value:
            bits |= 1
        if i > 0 and flat[cell - ny * nz] == value:
            bits |= 2
        if j + 1 < ny and flat[cell + nz] == value:
            bits |= 4
        if j > 0 and flat[cell - nz] == value:
            bits |= 8
        if k + 1 < nz and flat[cell + 1] == value:
            bits |= 16
        if k > 0 and flat[cell - 1] == value:
            bits |= 32
        facing[c] = bits
        for step in range(6):
            count[step] += (bits >> step) & 1
    return count


@compiled
def _write_faces(gone, shape, facing, step, start, stop, ijk, axis, sign, at):
    """The faces of the neighbours of ``gone[start:stop]`` towards direction
    ``step`` that :func:`_facing` marked, written from row ``at`` on: the
    neighbour's cell, the air on the side opposite ``step``."""
    ny, nz = shape[1], shape[2]
    offset = ny * nz if step < 2 else nz if step < 4 else 1
    if step % 2:
        offset = -offset
    n = at
    for c in range(start, stop):
        if (facing[c] >> step) & 1:
            cell = gone[c] + offset
            ijk[n, 0], ijk[n, 1], ijk[n, 2] = cell // (ny * nz), (cell // nz) % ny, cell % nz
            axis[n], sign[n] = step // 2, 2 * (step % 2) - 1
            n += 1
