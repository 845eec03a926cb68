"""Compiled passes of the classification (numba, :mod:`core.jit`): the
voxels' first labels, and the air under cover.

The first labels (:func:`label_columns`): numpy writes ground, the building
cells, the gaps and the air with grid-sized masks, eight passes over the
85 M voxels of the 1 km synthetic city and a slow ``np.maximum.at`` over the
building cells (0.22-0.43 s in a process's later runs, 0.6 s in its
first); here each column is written once (0.03 s).

The air front (:func:`core.classify.enclose_air`) can only miss air that
lies under something in its column: eaves, bridges, holes in roofs. numpy
finds those cells with grid-sized passes (the air mask, its complement, the
highest solid cell of every column by ``argmax``, the covered mask, its
indices): 0.09-0.17 s per call on the 85 M voxels of the 1 km synthetic
city, called three times a run, where the city has no such cell at all.
Here each column is read once from the top, on all cores (slabs of x), once
to count the covered cells and once to list them: the same cells,
ascending, and the same height of the highest solid cell per column.
"""
from __future__ import annotations

import numpy as np

from .neighbours_kernel import compiled
from .parallel import counted_then_listed, map_blocks, thread_blocks


def covered_air(labels: np.ndarray, air: int) -> tuple[np.ndarray, np.ndarray]:
    """The air cells below the highest solid (not ``air``) cell of their
    column, as ascending flat indices, and that height per column: the
    index of the highest solid cell plus one, 0 in a column of air only.

    Examples
    --------
    Air (3) under a roof cell at k = 2, and above it:

    >>> labels = np.full((1, 2, 4), 3, np.uint8); labels[0, 0, 2] = 2; labels[0, 0, 0] = 1
    >>> cells, top = covered_air(labels, 3)
    >>> cells.tolist(), top.tolist()
    ([1], [[3, 0]])
    """
    labels = np.ascontiguousarray(labels)
    nx, ny, nz = labels.shape
    top = np.zeros((nx, ny), dtype=np.int64)
    cells = counted_then_listed(lambda rows, out, at: _covered(labels, air, rows.start, rows.stop, top, out, at),
                                thread_blocks(nx))
    return cells, top


def label_columns(shape: tuple[int, int, int], ground_top_k: np.ndarray, cells: np.ndarray, fill_to_top: bool,
                  ground: int, building: int, air: int) -> np.ndarray:
    """:func:`core.classify.classify_voxels` before its air front: ``ground``
    up to each column's ``ground_top_k``, ``building`` in the ``cells``
    above it and in the gap from the ground up to the column's lowest (or,
    ``fill_to_top``, highest) such cell, ``air`` everywhere else.

    The building cells above the ground are read twice (their columns'
    limits, then written); each column is written once, on all cores.

    Examples
    --------
    >>> label_columns((1, 1, 6), np.array([[1]]), np.array([[0, 0, 3]]), False, 1, 2, 3).ravel().tolist()
    [1, 1, 2, 2, 3, 3]
    """
    nx, ny, nz = shape
    top = np.ascontiguousarray(ground_top_k, dtype=np.int64)
    cells = np.ascontiguousarray(cells, dtype=np.int64).reshape(-1, 3)
    limit = np.full((nx, ny), -1 if fill_to_top else nz, dtype=np.int64)
    has_building = np.zeros((nx, ny), dtype=np.bool_)
    _limits(cells, top, fill_to_top, limit, has_building)
    labels = np.empty(shape, dtype=np.uint8)
    map_blocks(lambda rows: _fill_columns(labels, top, limit, has_building, rows.start, rows.stop, ground, building,
                                          air), thread_blocks(nx))
    _paint_cells(labels, cells, top, building)
    return labels



def warm_up() -> int:
    """Compile for the labels the pipeline passes (uint8)."""
    labels = np.full((1, 2, 4), 3, np.uint8)
    labels[0, 0, 2] = 2
    cells, top = covered_air(labels, 3)
    assert cells.tolist() == [0, 1] and top.tolist() == [[3, 0]], (cells, top)
    for fill_to_top in (False, True):
        got = label_columns((1, 1, 6), np.array([[1]]), np.array([[0, 0, 3]]), fill_to_top, 1, 2, 3)
        assert got.ravel().tolist() == [1, 1, 2, 2, 3, 3], got
    return 1


@compiled
def _limits(cells, top, fill_to_top, limit, has_building):
    """The lowest (or highest) building cell above the ground of each column."""
    for c in range(len(cells)):
        i, j, k = cells[c, 0], cells[c, 1], cells[c, 2]
        if k <= top[i, j]:
            continue  # ground wins
        has_building[i, j] = True
        if (k > limit[i, j]) if fill_to_top else (k < limit[i, j]):
            limit[i, j] = k


@compiled
def _fill_columns(labels, top, limit, has_building, start, stop, ground, building, air):
    """Columns with x in ``start:stop``: ground, then the gap, then air."""
    nx, ny, nz = labels.shape
    for i in range(start, stop):
        for j in range(ny):
            gap = limit[i, j] if has_building[i, j] else 0
            for k in range(nz):
                if k <= top[i, j]:
                    labels[i, j, k] = ground
                elif k < gap:
                    labels[i, j, k] = building
                else:
                    labels[i, j, k] = air


@compiled
def _paint_cells(labels, cells, top, building):
    """The building cells above the ground."""
    for c in range(len(cells)):
        i, j, k = cells[c, 0], cells[c, 1], cells[c, 2]
        if k > top[i, j]:
            labels[i, j, k] = building


@compiled
def _covered(labels, air, start, stop, top, out, at):
    """Columns with x in ``start:stop``: their height of cover into ``top``,
    and their covered air cells counted, or written into ``out`` from ``at``
    on. Returns how many."""
    nx, ny, nz = labels.shape
    write = len(out) > 0
    n = 0
    for i in range(start, stop):
        for j in range(ny):
            height = 0
            for k in range(nz - 1, -1, -1):
                if labels[i, j, k] != air:
                    height = k + 1
                    break
            top[i, j] = height
            for k in range(height):
                if labels[i, j, k] == air:
                    if write:
                        out[at + n] = (i * ny + j) * nz + k
                    n += 1
    return n
