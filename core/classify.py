"""Sorting the voxels into ground, building and air (paper §2, figure 1).

The steps are the paper's, in its order:

1. ground points define ground voxels, and ground has priority: here every
   voxel at or below the column's ground level (:mod:`core.ground`);
2. the other points define building voxels;
3. empty cells between the ground and a building above it become building
   (this is what turns an airborne roof, with no facade point under it, into
   a solid);
4. air is flood-filled through face-adjacent empty cells from an extra empty
   row on top of the grid;
5. cells still unassigned (enclosed by building surfaces) become building,
   which removes the inner and spurious surfaces of STL models.

Airborne roofs have holes (dark or glass roofs, vegetation classified over
them): a column with neither ground nor building return, enclosed mostly by
building columns, would otherwise become a well of air down to the ground.
:func:`roof_hole_columns` finds them so that :func:`classify_voxels` can seed
them at the height of the roof around them.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from scipy import ndimage

from . import jit
from .errors import Cancelled
from .grid import VoxelGrid

UNASSIGNED, GROUND, BUILDING, AIR = 0, 1, 2, 3

#: Face adjacency (6-connectivity) in 3-D, as the paper's advancing fronts use.
FACE_ADJACENCY = ndimage.generate_binary_structure(3, 1)
#: Above one cell in this many under cover, :func:`enclose_air` labels the whole grid.
_MOSTLY_COVERED = 16


def classify_voxels(grid: VoxelGrid, ground_top_k: np.ndarray, building_cells: np.ndarray,
                    roof_seeds: np.ndarray | None = None, fill_to_top: bool = False,
                    is_cancelled: Callable[[], bool] | None = None) -> np.ndarray:
    """Label every voxel ground, building or air.

    Parameters
    ----------
    grid : VoxelGrid
    ground_top_k : ndarray of int, shape (nx, ny)
        Highest ground voxel of each column.
    building_cells : ndarray of int, shape (B, 3)
        Cells ``(i, j, k)`` holding at least one non-ground point.
    roof_seeds : ndarray of int, shape (S, 3), optional
        Extra building cells (roof holes, see :func:`roof_hole_columns`).
    fill_to_top : bool
        Fill the gap up to the *highest* building cell of each column instead
        of the lowest. For airborne point clouds: a scan from above sees the
        roof and, at most, scattered facade points; filling only up to the
        lowest facade point would leave the wall between it and the roof open
        to the air front.
    is_cancelled : callable, optional

    Returns
    -------
    ndarray of uint8, shape grid.shape
        ``GROUND``, ``BUILDING`` or ``AIR`` for every voxel.

    Examples
    --------
    A 1 x 1 column of 6 voxels, ground up to k = 1, one roof point at k = 3:
    the gap under the roof becomes building, the rest air.

    >>> g = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (1, 1, 6))
    >>> classify_voxels(g, np.array([[1]]), np.array([[0, 0, 3]])).ravel()
    array([1, 1, 2, 2, 3, 3], dtype=uint8)
    """
    cells = building_cells if roof_seeds is None else np.concatenate([building_cells, roof_seeds])
    # Each column written once, the same labels (core.classify_kernel).
    labels = jit.run("classify_kernel", "label_columns", grid.shape, ground_top_k, cells, fill_to_top,
                     GROUND, BUILDING, AIR, size=grid.n_voxels)
    if labels is None:
        labels = _label_columns(grid.shape, ground_top_k, cells, fill_to_top)
    if is_cancelled is not None and is_cancelled():
        raise Cancelled()
    enclose_air(labels)
    return labels


def _label_columns(shape: tuple[int, int, int], ground_top_k: np.ndarray, cells: np.ndarray,
                   fill_to_top: bool) -> np.ndarray:
    """:func:`classify_voxels` before the air front, with grid-sized masks."""
    nx, ny, nz = shape
    k = np.arange(nz, dtype=np.int32)
    labels = np.zeros(shape, dtype=np.uint8)
    is_ground = k[None, None, :] <= ground_top_k[:, :, None]
    labels[is_ground] = GROUND

    if len(cells):
        above = cells[:, 2] > ground_top_k[cells[:, 0], cells[:, 1]]  # ground wins
        cells = cells[above]
        labels[cells[:, 0], cells[:, 1], cells[:, 2]] = BUILDING
        # Gap between ground and the lowest (or highest) building cell of each column.
        if fill_to_top:
            limit = np.full((nx, ny), -1, dtype=np.int64)
            np.maximum.at(limit, (cells[:, 0], cells[:, 1]), cells[:, 2])
        else:
            limit = np.full((nx, ny), nz, dtype=np.int64)
            np.minimum.at(limit, (cells[:, 0], cells[:, 1]), cells[:, 2])
        has_building = np.zeros((nx, ny), dtype=bool)
        has_building[cells[:, 0], cells[:, 1]] = True
        gap = (k[None, None, :] < limit[:, :, None]) & ~is_ground & has_building[:, :, None]
        labels[gap] = BUILDING
    del is_ground
    labels[labels == UNASSIGNED] = AIR
    return labels


def enclose_air(labels: np.ndarray) -> int:
    """Keep as air only the cells the air front reaches; the rest become building.

    The paper's advancing front of air starts from an empty cell of the top
    row and crosses faces only; every cell it does not reach is enclosed by
    building surfaces and becomes building. Works in place.

    An air cell with no solid above it in its column is reached straight
    from the top row: only the air *under* something (eaves, bridges, holes
    in roofs) can be enclosed. Those cells, a small part of the grid, are
    grouped by their face adjacencies, and a group is reached when one of
    its cells has a face against open air. That is a labelling of all air
    cells (the front) made on the few that can be cut off.

    Returns
    -------
    int
        Number of air cells turned into building.

    Examples
    --------
    >>> lab = np.full((3, 3, 3), BUILDING, np.uint8); lab[1, 1, 0] = AIR; lab[:, :, 2] = AIR
    >>> enclose_air(lab), bool(lab[1, 1, 0] == BUILDING)
    (1, True)
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    nx, ny, nz = labels.shape
    cells, top = covered_air_cells(labels)
    if len(cells) == 0:
        return 0
    if len(cells) > labels.size // _MOSTLY_COVERED:
        # Hollow models (STL buildings are air inside their roofs): a
        # labelling of the grid costs less than a graph of that many cells.
        del cells
        components, _ = ndimage.label(labels == AIR, structure=FACE_ADJACENCY)
        top_ids = np.unique(components[:, :, -1])
        reached = np.zeros(int(components.max()) + 1, dtype=bool)
        reached[top_ids[top_ids > 0]] = True
        enclosed_mask = (components > 0) & ~reached[components]
        del components
        labels[enclosed_mask] = BUILDING
        return int(np.count_nonzero(enclosed_mask))
    flat_labels, flat_top = labels.reshape(-1), top.reshape(-1)
    ijk = np.unravel_index(cells, labels.shape)
    stride = (ny * nz, nz, 1)
    pairs, reached_cells = [], []
    for axis in range(3):
        for step in (-1, 1):
            inside = (ijk[axis] + step >= 0) & (ijk[axis] + step < labels.shape[axis])
            cell = np.flatnonzero(inside)
            neighbour = cells[cell] + step * stride[axis]
            # Covered: air below its column's highest solid cell.
            air = flat_labels[neighbour] == AIR
            covered = air & (neighbour % nz < flat_top[neighbour // nz])
            reached_cells.append(cell[air & ~covered])
            if step > 0:  # each adjacency once
                pairs.append(np.column_stack([cell[covered], np.searchsorted(cells, neighbour[covered])]))
    edges = np.concatenate(pairs)
    graph = coo_matrix((np.ones(len(edges), dtype=np.int8), (edges[:, 0], edges[:, 1])),
                       shape=(len(cells), len(cells)))
    _, group = connected_components(graph, directed=False)
    reached = np.zeros(group.max() + 1, dtype=bool)
    reached[group[np.concatenate(reached_cells)]] = True
    enclosed = cells[~reached[group]]
    labels[np.unravel_index(enclosed, labels.shape)] = BUILDING
    return int(len(enclosed))


def covered_air_cells(labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The air cells with a solid cell above them in their column (ascending
    flat indices), and per column the index of its highest solid cell plus
    one (0 in a column of air only).

    With numba one pass per column (:mod:`core.classify_kernel`), the same
    cells; here grid-sized passes.

    Examples
    --------
    >>> lab = np.full((1, 2, 4), AIR, np.uint8); lab[0, 0, 2] = BUILDING
    >>> cells, top = covered_air_cells(lab)
    >>> cells.tolist(), top.tolist()
    ([0, 1], [[3, 0]])
    """
    found = jit.run("classify_kernel", "covered_air", labels, AIR, size=labels.size)
    if found is not None:
        return found
    nz = labels.shape[2]
    air = labels == AIR
    solid = ~air
    top = nz - np.argmax(solid[:, :, ::-1], axis=2)
    top[~solid.any(axis=2)] = 0
    del solid
    covered = air & (np.arange(nz) < top[:, :, None])
    return np.flatnonzero(covered), top.astype(np.int64)


def hollow_share(labels: np.ndarray) -> float:
    """The share of the building columns that hold air under a solid cell.

    A closed building fills its columns from the ground to its roof
    (:func:`classify_voxels`, step 5), so only passages and overhangs leave
    air under it. A model whose walls are missing lets the air in, and most
    of its columns are then hollow: the mesh pipeline warns of it.

    Examples
    --------
    >>> lab = np.full((1, 2, 4), AIR, np.uint8); lab[0, :, 0] = GROUND; lab[0, :, 3] = BUILDING
    >>> lab[0, 0, 1:3] = BUILDING  # a solid column and a roof over air
    >>> hollow_share(lab)
    0.5
    """
    cells, _ = covered_air_cells(labels)
    columns = (labels == BUILDING).any(axis=2).sum()
    return float(len(np.unique(cells // labels.shape[2])) / columns) if columns else 0.0


def roof_hole_columns(building_columns: np.ndarray, ground_columns: np.ndarray,
                      building_top_k: np.ndarray, max_hole_cells: int,
                      min_building_share: float = 0.5) -> np.ndarray:
    """Seed cells for roof holes of airborne point clouds.

    A roof hole is a 4-connected group of columns with no return at all
    (neither ground nor building) whose rim is mostly building columns and
    whose area is at most ``max_hole_cells`` columns. A courtyard has ground
    returns, and a tree in a yard is ringed by ground columns, so neither is
    filled. Each hole column is seeded at the top of the nearest building
    column, so the gap rule of :func:`classify_voxels` makes it solid.

    Parameters
    ----------
    building_columns, ground_columns : ndarray of bool, shape (nx, ny)
        Columns with at least one building / ground point.
    building_top_k : ndarray of int, shape (nx, ny)
        Highest building cell of each building column.
    max_hole_cells : int
        Largest hole that is filled, in columns.
    min_building_share : float
        Fraction of rim columns that must be building columns.

    Returns
    -------
    ndarray of int, shape (S, 3)
        Building cells to add.

    Examples
    --------
    >>> b = np.ones((3, 3), bool); b[1, 1] = False
    >>> g = np.zeros((3, 3), bool)
    >>> roof_hole_columns(b, g, np.full((3, 3), 7), max_hole_cells=4)
    array([[1, 1, 7]])
    """
    empty = ~building_columns & ~ground_columns
    holes, n = ndimage.label(empty)
    if n == 0:
        return np.zeros((0, 3), dtype=np.int64)
    area = np.bincount(holes.ravel(), minlength=n + 1)
    # Rim of each hole: its empty columns' 4-neighbours that are not empty.
    rim_building = np.zeros(n + 1)
    rim_total = np.zeros(n + 1)
    touches_border = np.zeros(n + 1, bool)
    touches_border[np.unique(np.concatenate([holes[0], holes[-1], holes[:, 0], holes[:, -1]]))] = True
    for axis in (0, 1):
        for step in (1, -1):
            inner = holes
            neighbour_is_building = np.roll(building_columns, -step, axis=axis)
            neighbour_empty = np.roll(empty, -step, axis=axis)
            valid = np.ones_like(empty)
            edge = [slice(None)] * 2
            edge[axis] = slice(-1, None) if step == 1 else slice(0, 1)
            valid[tuple(edge)] = False  # np.roll wraps around: ignore the wrapped row
            sel = (inner > 0) & ~neighbour_empty & valid
            rim_total += np.bincount(inner[sel], minlength=n + 1)
            rim_building += np.bincount(inner[sel], weights=neighbour_is_building[sel], minlength=n + 1)
    share = np.divide(rim_building, rim_total, out=np.zeros_like(rim_total), where=rim_total > 0)
    fill = (area <= max_hole_cells) & (share >= min_building_share) & ~touches_border
    fill[0] = False
    hole_mask = fill[holes]
    if not hole_mask.any():
        return np.zeros((0, 3), dtype=np.int64)
    _, (ni, nj) = ndimage.distance_transform_edt(~building_columns, return_indices=True)
    hi, hj = np.nonzero(hole_mask)
    return np.column_stack([hi, hj, building_top_k[ni[hi, hj], nj[hi, hj]]]).astype(np.int64)
