"""Compiled passes over the labelled blocks (numba, :mod:`core.jit`).

The blocks' attributes (:func:`core.blocks.block_attributes`) need each
block's voxel count, the columns it covers and its lowest and highest
layer; dropping the small blocks (:func:`core.blocks.drop_blocks`,
:func:`core.blocks.keep_blocks`) turns their voxels into air and numbers
the others again. numpy does it with a list of the block voxels
(``flatnonzero`` of the grid), ``bincount``, a sort of the columns' keys and
``find_objects``, five passes over the 85 M voxels of the 1 km synthetic
city, twice a run (before and after the elimination): about 1 s. Here each
is one pass over the grid on all cores, slabs of x apart. The answers are
integers, the same either way.
"""
from __future__ import annotations

import numpy as np

from .neighbours_kernel import compiled
from .parallel import map_blocks, thread_blocks


def block_extents(blocks: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Voxel count, columns covered, lowest and highest layer of each block ``1..n``.

    A block that does not occur has its lowest layer ``nz`` and its highest -1.

    Examples
    --------
    An L of three voxels, two of them stacked:

    >>> b = np.array([[[1, 1]], [[1, 0]]], np.int32)
    >>> [a.tolist() for a in block_extents(b, 1)]
    [[3], [2], [0], [1]]
    """
    blocks = np.ascontiguousarray(blocks)
    nx, ny, nz = blocks.shape
    slabs = thread_blocks(nx)
    parts = map_blocks(lambda rows: _extents(blocks, n, rows.start, rows.stop), slabs)
    count = sum(part[0] for part in parts)
    columns = sum(part[1] for part in parts)
    lowest = np.minimum.reduce([part[2] for part in parts])
    highest = np.maximum.reduce([part[3] for part in parts])
    return count[1:], columns[1:], lowest[1:], highest[1:]


def drop_and_renumber(labels: np.ndarray, blocks: np.ndarray, new_id: np.ndarray, air: int) -> np.ndarray:
    """In place: the voxels of the blocks whose ``new_id`` is 0 become
    ``air`` in ``labels``, and every block voxel takes its block's
    ``new_id``. Returns ``blocks``.

    Examples
    --------
    >>> labels = np.full((1, 1, 3), 2, np.uint8)
    >>> blocks = np.array([[[1, 2, 0]]], np.int32)
    >>> drop_and_renumber(labels, blocks, np.array([0, 0, 1], np.int32), 0).ravel().tolist()
    [0, 1, 0]
    >>> labels.ravel().tolist()
    [0, 2, 2]
    """
    new_id = new_id.astype(blocks.dtype)
    map_blocks(lambda rows: _renumber(labels, blocks, new_id, air, rows.start, rows.stop),
               thread_blocks(blocks.shape[0]))
    return blocks


def warm_up() -> int:
    """Compile for the grids the pipeline passes (int32 blocks, uint8 labels)."""
    b = np.array([[[1, 1]], [[1, 0]]], np.int32)
    assert [a.tolist() for a in block_extents(b, 1)] == [[3], [2], [0], [1]]
    labels = np.full(b.shape, 2, np.uint8)
    drop_and_renumber(labels, b, np.array([0, 0], np.int32), 0)
    assert not b.any() and labels.ravel().tolist() == [0, 0, 0, 2]
    return 1


@compiled
def _extents(blocks, n, start, stop):
    """:func:`block_extents` of the slab ``start:stop`` of x (with the id 0 first)."""
    nx, ny, nz = blocks.shape
    count = np.zeros(n + 1, np.int64)
    columns = np.zeros(n + 1, np.int64)
    lowest = np.full(n + 1, nz, np.int64)
    highest = np.full(n + 1, -1, np.int64)
    # The column where each block was last seen: a block's voxels in a column
    # count that column once.
    seen_in = np.full(n + 1, -1, np.int64)
    for i in range(start, stop):
        for j in range(ny):
            column = i * ny + j
            for k in range(nz):
                b = blocks[i, j, k]
                if b == 0:
                    continue
                count[b] += 1
                if seen_in[b] != column:
                    seen_in[b] = column
                    columns[b] += 1
                if k < lowest[b]:
                    lowest[b] = k
                if k > highest[b]:
                    highest[b] = k
    return count, columns, lowest, highest


@compiled
def _renumber(labels, blocks, new_id, air, start, stop):
    """:func:`drop_and_renumber` on the slab ``start:stop`` of x."""
    nx, ny, nz = blocks.shape
    for i in range(start, stop):
        for j in range(ny):
            for k in range(nz):
                b = blocks[i, j, k]
                if b == 0:
                    continue
                renumbered = new_id[b]
                if renumbered == 0:
                    labels[i, j, k] = air
                blocks[i, j, k] = renumbered
