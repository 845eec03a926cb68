"""Which buildings of a city model each block holds.

A CityJSON file names its buildings (3D BAG's ``NL.IMBAG.Pand...``, a
cadastre's identifiers); the method turns their surfaces into voxels and the
voxels into blocks (§3.2), so that row houses that touch become one block, and
a building may also end up in no block (below the thresholds, outside the
extent) or, rarely, in two. A user joins the blocks to the buildings' own
attributes (year of construction, use) through these identifiers.

A building is in a block when the block covers at least :data:`LEAST_SHARE`
of the building's plan area: the area of its faces seen from above (its
roofs and floors; walls have almost none), each face counted in the grid
column under its centroid, and a column in the block when it is one of the
block's footprint columns (:attr:`core.reconstruction.Reconstruction.footprint_columns`).
A building without plan area (walls only) counts its faces' own areas instead.
The footprint columns are the model's whatever its tiles or clusters, so the
answer does not depend on how the run was cut. All faces at once: a few sorts
and sums, no loop over faces or buildings.

Example
-------
Two flat roofs of 2 x 1 m, one over columns (0, 0) and (1, 0) of 1 m, the
other over (5, 0) and (6, 0); block 1 covers the first's columns, block 2
one column of the second's:

>>> from core.readers.mesh import Triangles
>>> vertices = np.array([[0, 0, 5], [2, 0, 5], [2, 1, 5], [0, 1, 5],
...                      [5, 0, 5], [7, 0, 5], [7, 1, 5], [5, 1, 5]], float)
>>> faces = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
>>> roofs = Triangles(vertices, faces, owner=np.array([0, 0, 1, 1]), owner_ids=("a", "b"))
>>> columns = np.array([[1, 0, 0], [1, 1, 0], [2, 6, 0]])
>>> block_buildings(roofs, columns, np.array([1, 2]), np.zeros(2), 1.0)
([('a',), ('b',)], 0)
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .footprint import block_positions

if TYPE_CHECKING:  # core.readers imports laspy: only where a file is read
    from .readers.mesh import Triangles

__all__ = ["block_buildings", "LEAST_SHARE"]

#: Share of a building's plan area a block must cover to hold it.
LEAST_SHARE = 0.25


def block_buildings(triangles: Triangles, footprint_columns: np.ndarray, block_ids: np.ndarray,
                    corner: np.ndarray, size: float) -> tuple[list[tuple[str, ...]], int]:
    """The buildings each block holds (see the module doc).

    Parameters
    ----------
    triangles : Triangles
        The input's faces with their buildings (``owner``, ``owner_ids``), in
        world coordinates.
    footprint_columns : ndarray of int (P, 3)
        ``(block id, i, j)`` of every column a block covers.
    block_ids : ndarray of int (B,)
        The blocks, in the order wanted.
    corner : ndarray (2,)
        World x, y of the corner of column (0, 0).
    size : float
        A column's side.

    Returns
    -------
    buildings : list of tuple of str
        For each block of ``block_ids``, the identifiers of its buildings, sorted.
    n_in_none : int
        Buildings in no block.
    """
    block_ids = np.asarray(block_ids, dtype=np.int64)
    n_buildings = len(triangles.owner_ids)
    if triangles.owner is None or n_buildings == 0:
        return [() for _ in block_ids], 0
    corners = triangles.vertices[triangles.faces]
    edge_1, edge_2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    normal = np.cross(edge_1, edge_2)
    weight = 0.5 * np.abs(normal[:, 2])
    owner = np.asarray(triangles.owner, dtype=np.int64)
    total = np.bincount(owner, weights=weight, minlength=n_buildings)
    flat_less = total[owner] <= 0  # a building of walls only: their own areas
    weight[flat_less] = 0.5 * np.linalg.norm(normal[flat_less], axis=1)
    total = np.bincount(owner, weights=weight, minlength=n_buildings)

    face, block = _faces_in_blocks(corners.mean(axis=1)[:, :2], footprint_columns, corner, size)
    block = block_positions(block, block_ids)
    face, block = face.compress(block >= 0), block.compress(block >= 0)
    # The plan area of every (building, block) pair, summed.
    pair, inverse = np.unique(owner.take(face) * len(block_ids) + block, return_inverse=True)
    area = np.bincount(inverse, weights=weight.take(face), minlength=len(pair))
    building, block = np.divmod(pair, len(block_ids))
    held = area >= LEAST_SHARE * total.take(building)
    building, block = building.compress(held), block.compress(held)
    ids = np.asarray(triangles.owner_ids, dtype=object)
    # Blocks in order, each block's buildings by identifier.
    order = np.lexsort((ids.take(building).astype(str), block))
    building, block = building.take(order), block.take(order)
    start = np.searchsorted(block, np.arange(len(block_ids) + 1))
    out = [tuple(ids.take(building[start[b]:start[b + 1]]).tolist()) for b in range(len(block_ids))]
    in_some = np.zeros(n_buildings, dtype=bool)
    in_some[building] = True
    return out, int(n_buildings - in_some.sum())


def _faces_in_blocks(centre: np.ndarray, footprint_columns: np.ndarray, corner: np.ndarray,
                     size: float) -> tuple[np.ndarray, np.ndarray]:
    """Every (face, block id) pair of a face whose centre lies in a column of
    the block; a column under several blocks (one above the other) pairs its
    faces with each."""
    columns = np.asarray(footprint_columns, dtype=np.int64).reshape(-1, 3)
    if len(columns) == 0 or len(centre) == 0:
        return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64)
    i = np.floor((centre[:, 0] - corner[0]) / size)
    j = np.floor((centre[:, 1] - corner[1]) / size)
    low_i, low_j = columns[:, 1].min(), columns[:, 2].min()
    span_i, span_j = columns[:, 1].max() - low_i + 1, columns[:, 2].max() - low_j + 1
    inside = np.flatnonzero((i >= low_i) & (i < low_i + span_i) & (j >= low_j) & (j < low_j + span_j))
    key = (i.take(inside).astype(np.int64) - low_i) * span_j + (j.take(inside).astype(np.int64) - low_j)
    column_key = (columns[:, 1] - low_i) * span_j + (columns[:, 2] - low_j)
    by_key = np.argsort(column_key, kind="stable")
    column_key = column_key.take(by_key)
    first = np.searchsorted(column_key, key, side="left")
    count = np.searchsorted(column_key, key, side="right") - first
    face = np.repeat(inside, count)
    # Each face's columns: its first, then the next ones of the same key.
    nth = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    block = columns[:, 0].take(by_key).take(np.repeat(first, count) + nth)
    return face, block
