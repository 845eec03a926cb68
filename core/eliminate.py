"""Elimination of unsupported boundary voxels (paper §3.4, figure 3).

A building voxel that has a face against the air is removed when no data
point lies within ``support`` voxel sizes (the paper uses 0.6) of that face:
the voxel shares too little volume with the building it stands for. One
pass, as in the paper; the caller then rebuilds blocks and surfaces.

Faces against the ground are not tested: the data there is the ground, and
airborne LiDAR has no point at the foot of a wall. For airborne point clouds
(``extrude_roofs=True``) a wall face is also supported by a point *above*
it within the support distance horizontally: an airborne scan sees the roof
edge, not the facade, and the facade is the roof edge extruded down to the
ground. Without that rule every wall voxel under the roof would go.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.spatial import cKDTree

from .classify import AIR, BUILDING
from .errors import Cancelled
from .grid import VoxelGrid

#: Candidates examined per face when the quick ball tests cannot decide.
_CANDIDATES = 16


def air_faces(labels: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every building/air face: its building cell, axis and outward sign.

    Returns
    -------
    cells : ndarray of int, shape (F, 3)
    axis : ndarray of int, shape (F,)
    sign : ndarray of int, shape (F,)
        +1 when the air is on the positive side of the cell.
    """
    building = labels == BUILDING
    air = labels == AIR
    cells, axes, signs = [], [], []
    for axis in range(3):
        lo = [slice(None)] * 3
        hi = [slice(None)] * 3
        lo[axis] = slice(0, -1)
        hi[axis] = slice(1, None)
        for sign, mine, theirs in ((1, lo, hi), (-1, hi, lo)):
            found = np.argwhere(building[tuple(mine)] & air[tuple(theirs)])
            if sign == -1:
                found[:, axis] += 1
            cells.append(found)
            axes.append(np.full(len(found), axis))
            signs.append(np.full(len(found), sign))
    return np.concatenate(cells), np.concatenate(axes), np.concatenate(signs)


def unsupported_voxels(labels: np.ndarray, grid: VoxelGrid, points: np.ndarray,
                       support: float = 0.6, extrude_roofs: bool = False,
                       is_cancelled: Callable[[], bool] | None = None) -> np.ndarray:
    """Cells of the boundary voxels to eliminate.

    Parameters
    ----------
    labels : ndarray of uint8
        Voxel labels (``BUILDING``/``AIR``/``GROUND``).
    grid : VoxelGrid
    points : ndarray of shape (P, 3)
        Local coordinates of the building data points.
    support : float
        Support distance in voxel sizes (paper: 0.6).
    extrude_roofs : bool
        Also accept points above a wall face (airborne data, see module doc).

    Returns
    -------
    ndarray of int, shape (E, 3)

    Examples
    --------
    A 2-voxel building whose data only covers the lower voxel: the upper one goes.

    >>> lab = np.full((1, 1, 4), AIR, np.uint8); lab[0, 0, 0] = 1; lab[0, 0, 1:3] = BUILDING
    >>> g = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (1, 1, 4))
    >>> pts = np.array([[0.5, 0.5, 1.9], [0.1, 0.5, 1.5], [0.9, 0.5, 1.5],
    ...                 [0.5, 0.1, 1.5], [0.5, 0.9, 1.5]])
    >>> unsupported_voxels(lab, g, pts)
    array([[0, 0, 2]])
    """
    cells, axis, sign = air_faces(labels)
    if len(cells) == 0:
        return cells
    if len(points) == 0:
        return np.unique(cells, axis=0)
    h = grid.voxel_size
    centre = grid.origin + (cells + 0.5) * h
    centre[np.arange(len(cells)), axis] += sign * 0.5 * h
    tree = cKDTree(points)
    supported = _supported_3d(tree, points, centre, axis, h, support)
    if is_cancelled is not None and is_cancelled():
        raise Cancelled()
    if extrude_roofs:
        wall = ~supported & (axis < 2)
        if wall.any():
            supported[wall] = _supported_from_above(points, centre[wall], axis[wall], h, support)
    return np.unique(cells[~supported], axis=0)


def _supported_3d(tree: cKDTree, points: np.ndarray, centre: np.ndarray, axis: np.ndarray,
                  h: float, support: float) -> np.ndarray:
    """Whether a point lies within ``support * h`` of each square face."""
    r_inner = support * h                      # ball inside the supported zone
    r_outer = np.sqrt(support**2 + 0.5) * h    # ball containing it
    supported = tree.query_ball_point(centre, r_inner, return_length=True, workers=-1) > 0
    open_ = np.flatnonzero(~supported)
    if len(open_) == 0:
        return supported
    maybe = tree.query_ball_point(centre[open_], r_outer, return_length=True, workers=-1) > 0
    open_ = open_[maybe]
    if len(open_) == 0:
        return supported
    k = min(_CANDIDATES, len(points))
    _, idx = tree.query(centre[open_], k=k, distance_upper_bound=r_outer, workers=-1)
    idx = idx.reshape(len(open_), k)
    valid = idx < len(points)
    offset = points[np.where(valid, idx, 0)] - centre[open_, None, :]
    normal = np.take_along_axis(np.abs(offset), axis[open_, None, None], axis=2)[..., 0]
    excess = np.maximum(np.abs(offset) - 0.5 * h, 0.0)
    excess[np.arange(len(open_)), :, axis[open_]] = 0.0  # across the face: the normal part counts
    dist2 = normal**2 + (excess**2).sum(axis=2)
    supported[open_] = (valid & (dist2 <= r_inner**2)).any(axis=1)
    return supported


def _supported_from_above(points: np.ndarray, centre: np.ndarray, axis: np.ndarray,
                          h: float, support: float) -> np.ndarray:
    """Whether a point above each wall face lies within ``support * h`` of it horizontally."""
    tree = cKDTree(points[:, :2])
    r_outer = np.sqrt(support**2 + 0.25) * h
    k = min(2 * _CANDIDATES, len(points))
    _, idx = tree.query(centre[:, :2], k=k, distance_upper_bound=r_outer, workers=-1)
    idx = idx.reshape(len(centre), k)
    valid = idx < len(points)
    near = points[np.where(valid, idx, 0)]
    offset = near[..., :2] - centre[:, None, :2]
    across = np.take_along_axis(np.abs(offset), axis[:, None, None], axis=2)[..., 0]
    along = np.take_along_axis(np.abs(offset), (1 - axis)[:, None, None], axis=2)[..., 0]
    along = np.maximum(along - 0.5 * h, 0.0)
    above = near[..., 2] >= centre[:, None, 2] - 0.5 * h
    return (valid & above & (across**2 + along**2 <= (support * h) ** 2)).any(axis=1)
