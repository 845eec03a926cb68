"""Ground level of every grid column (paper §2).

The paper's only requirement is a segmentation of the data into ground and
other points. Airborne LiDAR has no ground return under roofs, and a
CityGML-derived mesh has ground only along the wall bottoms, so every column
without a ground point gets its level interpolated from the observed columns
around it: linearly along chords in eight directions across the gap, the
chords weighted by how near their ends are (:func:`_fill_missing`). Ground
voxels are then the voxels whose centre is at or below that level: a height
field, which keeps the ground a single volume as §3 assumes.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from . import jit
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


def column_ground_level(grid: VoxelGrid, ground_points: np.ndarray, world: bool = False) -> GroundLevel:
    """Ground height of every column from ground points.

    Parameters
    ----------
    grid : VoxelGrid
    ground_points : ndarray of shape (G, 3)
        Local coordinates of the ground points, or world ones if ``world``.
    world : bool
        Take ``ground_points`` in world coordinates: the grid's offset is
        subtracted on the way (:func:`_local_columns`), the same numbers as
        for ``ground_points - grid.offset`` without that copy of them all
        (the tiled run's 840 MB for the 2 km city's 35 M ground points).

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
    if world:
        column, height = _local_columns(grid, ground_points)
    else:
        column, height = grid.column_of(ground_points), ground_points[:, 2]
    counts = np.bincount(column, minlength=nx * ny)
    sums = np.bincount(column, weights=height, minlength=nx * ny)
    observed = counts > 0
    z = np.full(nx * ny, np.nan)
    z[observed] = sums[observed] / counts[observed]
    z = z.reshape(nx, ny)
    observed = observed.reshape(nx, ny)
    if not observed.all():
        z = _fill_missing(z, observed)
    # A voxel is ground when its centre is at or below the ground level: the
    # voxel cut by the terrain goes to whichever side holds most of it, so the
    # building volume above the ground is unbiased (taking every voxel that
    # contains a ground point would lose half a voxel of every building).
    top_k = np.floor((z - grid.origin[2]) / grid.voxel_size - 0.5).astype(np.int64)
    np.clip(top_k, 0, grid.shape[2] - 1, out=top_k)
    return GroundLevel(z=z, top_k=top_k, observed=observed)


def _local_columns(grid: VoxelGrid, points: np.ndarray, chunk: int = 1 << 20) -> tuple[np.ndarray, np.ndarray]:
    """Column number and local height of points given in world coordinates.

    Examples
    --------
    >>> g = VoxelGrid(np.array([100.0, 200.0, 10.0]), np.zeros(3), 1.0, (3, 3, 5))
    >>> column, height = _local_columns(g, np.array([[100.5, 202.5, 11.0], [102.5, 200.5, 12.5]]))
    >>> column.tolist(), height.tolist()
    ([2, 6], [1.0, 2.5])
    """
    # The same numbers in one pass on all cores (core.grid_kernel): 0.5-0.8 ->
    # 0.15 s for the 2 km city's 35 M ground points.
    found = jit.run("grid_kernel", "local_columns", points, grid.offset, grid.origin, grid.voxel_size,
                    grid.shape, size=len(points))
    if found is not None:
        return found
    column = np.empty(len(points), dtype=np.int64)
    height = np.empty(len(points), dtype=np.float64)
    for start in range(0, len(points), chunk):
        local = points[start:start + chunk] - grid.offset
        column[start:start + len(local)] = grid.column_of(local)
        height[start:start + len(local)] = local[:, 2]
    return column, height


def column_ceiling(grid: VoxelGrid, ground_points: np.ndarray) -> np.ndarray:
    """An upper bound of the height of the ground points in every column
    (-inf where there is none), from three sums per column.

    No sample lies further above its mean than ``sigma * sqrt(n - 1)``
    (Samuelson's inequality, ``sigma`` the population standard deviation),
    plus a margin of a thousandth of a voxel for round-off. The measures use
    it to skip the search of the ground for nodes well above it: a maximum
    per column (``np.maximum.at``) took four times longer on 7 M points.

    Examples
    --------
    >>> g = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (2, 1, 4))
    >>> pts = np.array([[0.5, 0.5, 1.0], [0.5, 0.5, 1.2], [0.5, 0.5, 1.1]])
    >>> ceiling = column_ceiling(g, pts)
    >>> bool(1.2 <= ceiling[0, 0] < 1.3), float(ceiling[1, 0])
    (True, -inf)
    """
    nx, ny, _ = grid.shape
    column = grid.column_of(ground_points)
    z = ground_points[:, 2]
    n = np.bincount(column, minlength=nx * ny).astype(np.float64)
    some = n > 0
    mean = np.bincount(column, weights=z, minlength=nx * ny)[some] / n[some]
    square = np.bincount(column, weights=z * z, minlength=nx * ny)[some] / n[some]
    spread = np.sqrt(np.maximum(square - mean * mean, 0.0) * (n[some] - 1))
    ceiling = np.full(nx * ny, -np.inf)
    ceiling[some] = mean + spread + 1e-3 * grid.voxel_size
    return ceiling.reshape(nx, ny)


class NearGround:
    """Which points may have a ground point within a distance: those not
    farther than it above the ceiling of the ground (:func:`column_ceiling`)
    in the columns within that distance. For
    :func:`core.neighbours.nearest_distance`, whose searches of the ground
    then skip the roofs and walls high above it.

    Examples
    --------
    >>> g = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (3, 1, 9))
    >>> near = NearGround(g, np.array([[0.5, 0.5, 1.0]]))
    >>> near(np.array([[2.5, 0.5, 1.5], [0.5, 0.5, 6.0]]), 1.0).tolist()
    [False, False]
    >>> near(np.array([[2.5, 0.5, 1.5], [0.5, 0.5, 6.0]]), 2.0).tolist()
    [True, False]
    """

    def __init__(self, grid: VoxelGrid, ground_points: np.ndarray):
        self.grid = grid
        self.ceiling = column_ceiling(grid, ground_points)
        #: The ceiling's maximum over (2 r + 1)^2 columns, per r met.
        self.around: dict[int, np.ndarray] = {}

    def __call__(self, points: np.ndarray, reach: float) -> np.ndarray:
        # Points within ``reach`` of each other are at most r columns apart.
        r = int(np.ceil(reach / self.grid.voxel_size))
        if r not in self.around:
            self.around[r] = ndimage.maximum_filter(self.ceiling, size=2 * r + 1, mode="nearest").ravel()
        return points[:, 2] - reach <= self.around[r].take(self.grid.column_of(points))


#: Directions of the chords (each also taken backwards): the axes, the
#: diagonals and the knight's moves. The axes alone guessed worse (mean
#: error 0.115 against 0.087 m on Delft at 0.5 m, see :func:`_fill_missing`).
CHORD_DIRECTIONS = ((1, 0), (0, 1), (1, 1), (1, -1), (2, 1), (1, 2), (2, -1), (1, -2))


def _fill_missing(z: np.ndarray, observed: np.ndarray) -> np.ndarray:
    """Interpolate the unobserved columns from the observed ones around them.

    Along each of :data:`CHORD_DIRECTIONS`, a gap column lies on a chord
    between the nearest observed column behind it and the nearest ahead; the
    chord gives it the linear interpolation of their levels. The chords'
    values are averaged, each weighted by the inverse fourth power of the
    distance to its nearer end: the observed ground closest to a column
    counts most. A plane is interpolated exactly. Columns with no chord (a
    gap open to the grid's edge on every side) take the level of the
    nearest observed column.

    Why chords and not a triangulation: linear interpolation over a Delaunay
    triangulation of the gaps' rims (qhull; this module's method until
    December 2026) took 1.3 s on the 1 km synthetic city (85 k rim columns
    on a lattice, degenerate for qhull) and 5.7 s on the 2 km one; the
    chords took 0.13-0.19 s on the 1 km city in numpy then (0.37-0.58 s on
    other days), and take 0.04-0.06 s compiled (:mod:`core.ground_kernel`).
    Both guess the same thing, the ground under a roof, about equally well:
    the file's own roof gaps laid over its observed ground elsewhere (six
    shifts; the observed levels as the truth) are filled with a mean error
    of 0.087 m (chords) against
    0.085 m (triangulation) on Delft at 0.5 m, 0.053 against 0.050 m on
    Montpellier at 1 m, 0.078 against 0.068 m on Saint-Barthelemy at 0.5 m
    and 0.109 against 0.117 m on the hilly Jura village at 0.5 m
    (``tests/test_real_data.py`` checks Delft, Montpellier and the Jura
    against the triangulation).

    Examples
    --------
    A gap in a tilted plane is filled exactly:

    >>> x, y = np.meshgrid(np.arange(6.0), np.arange(5.0), indexing="ij")
    >>> z = 2 + 0.5 * x - 0.25 * y
    >>> gap = (x > 0) & (x < 4) & (y > 0) & (y < 3)
    >>> bool(np.allclose(_fill_missing(np.where(gap, np.nan, z), ~gap), z))
    True
    """
    missing = np.flatnonzero(~observed)
    if len(missing) == 0:
        return z
    weight = chord_weights(observed.shape)
    found = jit.run("ground_kernel", "chord_sums", observed, z.ravel(), np.array(CHORD_DIRECTIONS), weight,
                    size=observed.size)
    total, weights = found if found is not None else _chord_sums(z, observed, missing, weight)
    filled = z.copy()
    spanned = weights > 0
    filled.ravel()[missing[spanned]] = total[spanned] / weights[spanned]
    if not spanned.all():
        # No chord: the level of the nearest observed column.
        _, (ni, nj) = ndimage.distance_transform_edt(~observed, return_indices=True)
        alone = missing[~spanned]
        filled.ravel()[alone] = z[ni.ravel()[alone], nj.ravel()[alone]]
    return filled


def chord_weights(shape: tuple[int, int]) -> np.ndarray:
    """The weight of a chord along each of :data:`CHORD_DIRECTIONS` whose
    nearer end is ``k`` steps away, at ``[d, k - 1]``: the inverse fourth
    power of that distance in columns (``k`` up to the grid's longer side).

    A table of them, so that numpy and :mod:`core.ground_kernel` take the
    same numbers: numpy's ``power`` is not the C library's ``pow`` to the
    last bit on every machine (this one's vector instructions).

    Examples
    --------
    >>> chord_weights((3, 2))[0].tolist()  # along x: 1, 1/2^4, 1/3^4
    [1.0, 0.0625, 0.012345679012345678]
    """
    steps = np.arange(1, max(shape) + 1)
    return np.stack([(steps * float(np.hypot(di, dj))) ** -4.0 for di, dj in CHORD_DIRECTIONS])


def _chord_sums(z: np.ndarray, observed: np.ndarray, missing: np.ndarray,
                weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For the columns ``missing`` (``flatnonzero(~observed)``): the sum of
    their chords' levels, each times its weight (:func:`chord_weights`),
    and the sum of those weights; a direction at a time, each from the
    steps :func:`steps_to_observed` finds (numpy's way; compiled in
    :func:`core.ground_kernel.chord_sums`)."""
    ny = z.shape[1]
    mi, mj = np.divmod(missing, ny)
    level = z.ravel()
    total = np.zeros(len(missing))
    weights = np.zeros(len(missing))
    for d, (di, dj) in enumerate(CHORD_DIRECTIONS):
        behind = steps_to_observed(observed, di, dj).ravel().take(missing)
        ahead = steps_to_observed(observed[::-1, ::-1], di, dj)[::-1, ::-1].ravel().take(missing)
        chord = (behind > 0) & (ahead > 0)
        b, a = behind[chord], ahead[chord]
        ci, cj = mi[chord], mj[chord]
        z_behind = level.take((ci - b * di) * ny + (cj - b * dj))
        z_ahead = level.take((ci + a * di) * ny + (cj + a * dj))
        w = weight[d].take(np.minimum(a, b) - 1)
        total[chord] += w * (z_behind + (z_ahead - z_behind) * (b / (a + b)))
        weights[chord] += w
    return total, weights


def steps_to_observed(observed: np.ndarray, di: int, dj: int) -> np.ndarray:
    """Steps of ``(di, dj)`` back from every column to the nearest observed
    column on its line (0 on an observed column, -1 if there is none).

    One pass over the rows (each row from the row ``di`` before it), or over
    the columns when ``di`` is 0: a loop of a few thousand vectorised steps.

    Examples
    --------
    >>> steps_to_observed(np.array([[True, False, False], [False, False, True]]), 0, 1).tolist()
    [[0, 1, 2], [-1, -1, 0]]
    >>> steps_to_observed(np.array([[True, False], [False, False]]), 1, 1).tolist()
    [[0, -1], [-1, 1]]
    """
    if di == 0:
        return steps_to_observed(observed.T, dj, di).T
    nx, ny = observed.shape
    steps = np.full((nx, ny), -1, dtype=np.int32)
    lo, hi = max(dj, 0), ny + min(dj, 0)  # the columns j whose j - dj is on the grid
    for i in range(nx):
        row = steps[i]
        if i >= di:
            before = steps[i - di, lo - dj:hi - dj]
            row[lo:hi] = np.where(before >= 0, before + 1, -1)
        row[observed[i]] = 0
    return steps
