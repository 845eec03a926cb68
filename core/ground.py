"""Ground level of every grid column (paper §2).

The paper's only requirement is a segmentation of the data into ground and
other points. Airborne LiDAR has no ground return under roofs, and a
CityGML-derived mesh has ground only along the wall bottoms, so every column
without a ground point gets its level interpolated linearly from the columns
around it (nearest value outside their convex hull). Ground voxels are then
the voxels whose centre is at or below that level: a height field, which
keeps the ground a single volume as §3 assumes.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.interpolate import LinearNDInterpolator
from scipy.spatial import QhullError

from .errors import UrbanvoxError
from .grid import VoxelGrid


@dataclass
class GroundLevel:
    """The ground of every column.

    Attributes
    ----------
    z : ndarray of shape (nx, ny)
        Local ground height of each column.
    top_k : ndarray of shape (nx, ny)
        Index of the highest ground voxel of each column: voxel ``(i, j, k)``
        is ground when ``k <= top_k[i, j]``.
    observed : ndarray of bool, shape (nx, ny)
        Columns that contain at least one ground point.
    """

    z: np.ndarray
    top_k: np.ndarray
    observed: np.ndarray


def column_ground_level(grid: VoxelGrid, ground_points: np.ndarray) -> GroundLevel:
    """Ground height of every column from ground points.

    Parameters
    ----------
    grid : VoxelGrid
    ground_points : ndarray of shape (G, 3)
        Local coordinates of the ground points.

    Returns
    -------
    GroundLevel

    Examples
    --------
    Ground points in the four corner columns of a 3 x 3 grid, on the plane
    z = x; the other columns get the linear interpolation:

    >>> g = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (3, 3, 5))
    >>> pts = np.array([[x, y, x] for x in (0.5, 2.5) for y in (0.5, 2.5)])
    >>> column_ground_level(g, pts).z
    array([[0.5, 0.5, 0.5],
           [1.5, 1.5, 1.5],
           [2.5, 2.5, 2.5]])
    """
    if len(ground_points) == 0:
        raise UrbanvoxError("No ground point: set the ground classes (GROUND_CLASSES) "
                            "to the codes your data uses for the ground.")
    nx, ny, _ = grid.shape
    column = grid.column_of(ground_points)
    counts = np.bincount(column, minlength=nx * ny)
    sums = np.bincount(column, weights=ground_points[:, 2], minlength=nx * ny)
    observed = counts > 0
    z = np.full(nx * ny, np.nan)
    z[observed] = sums[observed] / counts[observed]
    z = z.reshape(nx, ny)
    observed = observed.reshape(nx, ny)
    if not observed.all():
        z = _fill_missing(grid, z, observed)
    # A voxel is ground when its centre is at or below the ground level: the
    # voxel cut by the terrain goes to whichever side holds most of it, so the
    # building volume above the ground is unbiased (taking every voxel that
    # contains a ground point would lose half a voxel of every building).
    top_k = np.floor((z - grid.origin[2]) / grid.voxel_size - 0.5).astype(np.int64)
    np.clip(top_k, 0, grid.shape[2] - 1, out=top_k)
    return GroundLevel(z=z, top_k=top_k, observed=observed)


def _fill_missing(grid: VoxelGrid, z: np.ndarray, observed: np.ndarray) -> np.ndarray:
    """Interpolate the unobserved columns from the observed ones around them.

    Only observed columns that touch an unobserved one take part in the
    triangulation: interior columns cannot influence a linear interpolation
    of the gaps, and leaving them out keeps Delaunay small on city-sized grids.
    """
    # Isolated empty columns (sparse returns at small voxels) first take the
    # mean of their observed neighbours: cheap, and it keeps the Delaunay
    # triangulation below for the real gaps (under roofs).
    ring = np.ones((3, 3))
    known = np.where(observed, z, 0.0)
    neighbours = ndimage.convolve(observed.astype(np.float64), ring, mode="constant")
    total = ndimage.convolve(known, ring, mode="constant")
    scattered = ~observed & (neighbours == 8)  # symmetric: exact on a plane
    z = z.copy()
    z[scattered] = total[scattered] / neighbours[scattered]
    observed = observed | scattered
    missing = ~observed
    if not missing.any():
        return z
    rim = observed & ndimage.binary_dilation(missing, structure=np.ones((3, 3), bool))
    xs, ys = grid.column_centres()
    ri, rj = np.nonzero(rim)
    mi, mj = np.nonzero(missing)
    filled = z.copy()
    if len(ri) >= 3:
        try:
            interpolate = LinearNDInterpolator(np.column_stack([xs[ri], ys[rj]]), z[ri, rj])
            filled[mi, mj] = interpolate(np.column_stack([xs[mi], ys[mj]]))
        except QhullError:
            pass  # collinear rim: the nearest-value fill below covers every column
    still = np.isnan(filled)
    if still.any():
        # Outside the rim's convex hull: the value of the nearest observed column.
        _, (ni, nj) = ndimage.distance_transform_edt(~observed, return_indices=True)
        filled[still] = z[ni[still], nj[still]]
    return filled
