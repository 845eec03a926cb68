"""Elimination of unsupported boundary voxels (paper §3.4, figure 3).

A building voxel that has a face against the air is removed when no data
point lies within ``support`` voxel sizes (the paper uses 0.6) of that face:
the voxel shares too little volume with the building it stands for. The
voxels a pass exposes are tested by further passes; the caller then
rebuilds blocks and surfaces.

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
from .neighbours import nearest_within, search_tree
from .parallel import map_blocks, row_blocks, thread_count

#: Candidates examined per face when the quick ball tests cannot decide.
_CANDIDATES = 16
#: Faces tested at a time; rows of their candidate tables per block on a core.
_FACES, _ROWS = 1 << 17, 4096


def eliminate_unsupported(labels: np.ndarray, grid: VoxelGrid, points: np.ndarray,
                          support: float = 0.6, extrude_roofs: bool = False, max_passes: int = 10,
                          is_cancelled: Callable[[], bool] | None = None, tree: cKDTree | None = None,
                          index=None) -> int:
    """Turn unsupported boundary voxels into air, in place, until none is left.

    The paper's single pass leaves the voxels it exposes untested: a voxel
    behind an eliminated one (typically at the foot of a wall, behind a
    column of voxels that held only a stray point) had no air face when the
    pass ran. Later passes test only the voxels next to those just removed.

    Parameters
    ----------
    labels : ndarray of uint8
        Voxel labels (``BUILDING``/``AIR``/``GROUND``), changed in place.
    grid : VoxelGrid
    points : ndarray of shape (P, 3)
        Local coordinates of the building data points.
    support : float
        Support distance in voxel sizes (paper: 0.6).
    extrude_roofs : bool
        Also accept points above a wall face (airborne data, see module doc).
    tree : cKDTree, optional
        ``search_tree(points)``, when the caller has it (it is made otherwise).
    index : ColumnIndex, optional
        A compiled index over ``points`` (:func:`core.neighbours.point_index`):
        it finds each face's nearest point, the same as the tree, faster.

    Returns
    -------
    int
        Number of voxels eliminated.

    Examples
    --------
    A 2-voxel building whose data only covers the lower voxel: the upper one goes.

    >>> lab = np.full((1, 1, 4), AIR, np.uint8); lab[0, 0, 0] = 1; lab[0, 0, 1:3] = BUILDING
    >>> g = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (1, 1, 4))
    >>> pts = np.array([[0.5, 0.5, 1.9], [0.1, 0.5, 1.5], [0.9, 0.5, 1.5],
    ...                 [0.5, 0.1, 1.5], [0.5, 0.9, 1.5]])
    >>> eliminate_unsupported(lab, g, pts), lab.ravel().tolist()
    (1, [1, 2, 3, 3])
    """
    test = _SupportTest(points, grid, support, extrude_roofs, tree, index)
    flat = labels.reshape(-1)
    shape = np.asarray(labels.shape)
    stride = np.array([shape[1] * shape[2], shape[2], 1], dtype=np.int64)
    exposed = None  # flat indices of voxels next to the last removals
    total = 0
    for _ in range(max_passes):
        if is_cancelled is not None and is_cancelled():
            raise Cancelled()
        candidates = np.flatnonzero(flat == BUILDING) if exposed is None else exposed[flat[exposed] == BUILDING]
        cells, axis, sign = air_faces(flat, candidates, shape, stride)
        if len(cells) == 0:
            break
        # take and compress: row gathers faster than indexing (core.vectors).
        gone = np.unique(cells.compress(~test(cells, axis, sign), axis=0) @ stride)
        if len(gone) == 0:
            break
        flat[gone] = AIR
        total += len(gone)
        ijk = np.column_stack(np.unravel_index(gone, labels.shape))
        around = (ijk[:, None, :] + _SIX[None, :, :]).reshape(-1, 3)
        around = around.compress(np.all((around >= 0) & (around < shape), axis=1), axis=0)
        exposed = np.unique(around @ stride)
    return total


_SIX = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])


def air_faces(flat: np.ndarray, cells: np.ndarray, shape: np.ndarray,
              stride: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The building/air faces of the given building cells.

    Parameters
    ----------
    flat : ndarray of uint8
        The labels, raveled (C order).
    cells : ndarray of int
        Flat indices of the building cells to look at.
    shape, stride : ndarray of int
        Grid shape and the strides of the flat index.

    Returns
    -------
    cells : ndarray of int, shape (F, 3)
        The building cell of each face.
    axis : ndarray of int, shape (F,)
    sign : ndarray of int, shape (F,)
        +1 when the air is on the positive side of the cell.
    """
    ijk = np.column_stack(np.unravel_index(cells, tuple(shape)))
    out_cells, out_axis, out_sign = [], [], []
    for step in _SIX:
        # One coordinate changes: the neighbour's flat index is one stride away.
        axis = int(np.flatnonzero(step)[0])
        moved = ijk[:, axis] + step[axis]
        inside = (moved >= 0) & (moved < shape[axis])
        facing = np.zeros(len(cells), dtype=bool)
        facing[inside] = flat[cells[inside] + step[axis] * stride[axis]] == AIR
        out_cells.append(ijk.compress(facing, axis=0))
        out_axis.append(np.full(int(facing.sum()), axis))
        out_sign.append(np.full(int(facing.sum()), int(step[axis])))
    return np.concatenate(out_cells), np.concatenate(out_axis), np.concatenate(out_sign)


class _SupportTest:
    """Whether data supports faces; the KD-trees are built once for all passes."""

    def __init__(self, points: np.ndarray, grid: VoxelGrid, support: float, extrude_roofs: bool,
                 tree: cKDTree | None = None, index=None):
        self.points = points
        self.index = index
        self.grid = grid
        self.support = support
        self.extrude_roofs = extrude_roofs
        self.tree = (tree if tree is not None else search_tree(points)) if len(points) else None
        self.tree_2d = search_tree(points[:, :2]) if len(points) and extrude_roofs else None

    def __call__(self, cells: np.ndarray, axis: np.ndarray, sign: np.ndarray) -> np.ndarray:
        if self.tree is None:
            return np.zeros(len(cells), dtype=bool)
        # A block of faces at a time: the candidate tables (faces x 16 or 32
        # neighbours, several arrays of them) stay small, where all the
        # faces of a city at once took a gigabyte. Each face is tested on
        # its own, so the blocks give the answers of one pass.
        supported = np.empty(len(cells), dtype=bool)
        for block in row_blocks(len(cells), _FACES):
            supported[block] = self._supported(cells[block], axis[block], sign[block])
        return supported

    def _supported(self, cells: np.ndarray, axis: np.ndarray, sign: np.ndarray) -> np.ndarray:
        h = self.grid.voxel_size
        centre = self.grid.origin + (cells + 0.5) * h
        centre[np.arange(len(cells)), axis] += sign * 0.5 * h
        supported = _supported_3d(self.tree, self.points, centre, axis, h, self.support, self.index)
        if self.tree_2d is not None:
            wall = ~supported & (axis < 2)
            if wall.any():
                supported[wall] = _supported_from_above(self.tree_2d, self.points,
                                                        centre.compress(wall, axis=0), axis[wall], h,
                                                        self.support)
        return supported


def _supported_3d(tree: cKDTree, points: np.ndarray, centre: np.ndarray, axis: np.ndarray,
                  h: float, support: float, search=None) -> np.ndarray:
    """Whether a point lies within ``support * h`` of each square face.

    ``search`` finds the nearest point (``tree`` by default; a compiled index,
    :func:`core.neighbours.point_index`, finds the same distance faster)."""
    search = tree if search is None else search
    r_inner = support * h                      # ball inside the supported zone
    r_outer = np.sqrt(support**2 + 0.5) * h    # ball containing it
    # The nearest point answers both ball tests ("a point within r_inner",
    # "a point within r_outer"): one search that stops at the first point,
    # instead of counting every point in two balls.
    nearest = nearest_within(search, centre, r_outer * (1 + 1e-6))
    supported = _within(tree, centre, nearest, r_inner)
    open_ = np.flatnonzero(~supported)
    if len(open_) == 0:
        return supported
    maybe = _within(tree, centre.take(open_, axis=0), nearest[open_], r_outer)
    open_ = open_[maybe]
    if len(open_) == 0:
        return supported
    k = min(_CANDIDATES, len(points))
    _, idx = tree.query(centre.take(open_, axis=0), k=k, distance_upper_bound=r_outer, workers=thread_count())
    idx = idx.reshape(len(open_), k)

    def test(rows: slice) -> np.ndarray:
        # One (F, k) array per coordinate: no ufunc loops three elements long.
        # Across the face the normal distance counts, along it only what lies
        # beyond the face's edge (the sums run x, y, z as before).
        near, faces = idx[rows], open_[rows]
        valid = near < len(points)
        near = np.where(valid, near, 0)
        face_axis = axis[faces, None]
        dist2 = 0.0
        for c in range(3):
            gap = np.abs(points[:, c][near] - centre[faces, c, None])
            excess = np.where(face_axis == c, 0.0, np.maximum(gap - 0.5 * h, 0.0))
            dist2 = dist2 + excess**2
            normal = gap if c == 0 else np.where(face_axis == c, gap, normal)
        dist2 = normal**2 + dist2
        return (valid & (dist2 <= r_inner**2)).any(axis=1)

    # Each face from its own row: blocks of rows on all cores.
    supported[open_] = np.concatenate(map_blocks(test, row_blocks(len(open_), _ROWS)))
    return supported


def _within(tree: cKDTree, centre: np.ndarray, nearest: np.ndarray, radius: float) -> np.ndarray:
    """Whether a data point lies within ``radius`` of each centre, as a ball
    query counts it (distance at most ``radius``).

    ``nearest`` is the distance to the nearest point (``inf`` when none was
    looked for that far). A ball query compares squared distances: where the
    nearest distance is within round-off of ``radius`` (data on a lattice puts
    points right on the sphere) the ball query itself decides, so every
    decision is the one it makes.

    Examples
    --------
    >>> tree = cKDTree(np.array([[0.6, 0.0, 0.0]]))
    >>> centre = np.zeros((3, 3)); centre[1, 0] = -0.1; centre[2, 0] = 0.1
    >>> _within(tree, centre, tree.query(centre)[0], 0.6).tolist()
    [True, False, True]
    """
    inside = nearest <= radius
    close = np.flatnonzero(np.abs(nearest - radius) <= 1e-9 * radius)
    if len(close):
        inside[close] = tree.query_ball_point(centre.take(close, axis=0), radius, return_length=True) > 0
    return inside


def _supported_from_above(tree: cKDTree, points: np.ndarray, centre: np.ndarray, axis: np.ndarray,
                          h: float, support: float) -> np.ndarray:
    """Whether a point above each wall face lies within ``support * h`` of it horizontally."""
    r_outer = np.sqrt(support**2 + 0.25) * h
    k = min(2 * _CANDIDATES, len(points))
    _, idx = tree.query(centre[:, :2], k=k, distance_upper_bound=r_outer, workers=thread_count())
    idx = idx.reshape(len(centre), k)

    def test(rows: slice) -> np.ndarray:
        # One (F, k) array per coordinate (see _supported_3d).
        near, at, face_axis = idx[rows], centre[rows], axis[rows, None]
        valid = near < len(points)
        near = np.where(valid, near, 0)
        dx = np.abs(points[:, 0][near] - at[:, 0, None])
        dy = np.abs(points[:, 1][near] - at[:, 1, None])
        across = np.where(face_axis == 0, dx, dy)
        along = np.maximum(np.where(face_axis == 0, dy, dx) - 0.5 * h, 0.0)
        above = points[:, 2][near] >= at[:, None, 2] - 0.5 * h
        return (valid & above & (across**2 + along**2 <= (support * h) ** 2)).any(axis=1)

    return np.concatenate(map_blocks(test, row_blocks(len(centre), _ROWS)) or [np.zeros(0, dtype=bool)])
