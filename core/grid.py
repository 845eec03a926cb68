"""The voxel lattice of paper §2: origin, voxel size, shape and equation (1).

All coordinates inside the pipeline are *local*: world coordinates minus
:attr:`VoxelGrid.offset`, so that large projected coordinates (2.6e6 m in
LV95, 6.6e6 m in Lambert-93) keep sub-millimetre precision in every
difference the method takes.

Arrays over the grid are indexed ``[i, j, k]`` (x, y, z). The paper's voxel
number ``i + nx*j + nx*ny*k`` (eq. 1) is the Fortran-order ravel of that
index, available as :meth:`VoxelGrid.voxel_number`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import jit
from .errors import UrbanvoxError
from .parallel import balanced_blocks, map_blocks, row_blocks

#: Points per block of :func:`bounds` (a few MB).
_BOUND_ROWS = 1 << 16
#: Points binned at once by :meth:`VoxelGrid.occupancy`: the float temporaries of a
#: chunk (~2 MB) stay in the CPU cache, and the memory used does not grow with the cloud.
BIN_CHUNK = 1 << 16


@dataclass(frozen=True)
class VoxelGrid:
    """A regular grid of cubic voxels.

    Parameters
    ----------
    offset : ndarray of shape (3,)
        World coordinates of the local origin (subtracted from all data).
    origin : ndarray of shape (3,)
        Local coordinates of the lower corner of voxel ``(0, 0, 0)``.
    voxel_size : float
        Edge length of a voxel, in CRS units.
    shape : tuple of int
        ``(nx, ny, nz)``.

    Examples
    --------
    >>> g = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (4, 3, 2))
    >>> g.cell_of(np.array([[0.5, 2.5, 1.2]]))
    array([[0, 2, 1]])
    >>> int(g.voxel_number(np.array([[0, 2, 1]]))[0])   # 0 + 4*2 + 4*3*1
    20
    """

    offset: np.ndarray
    origin: np.ndarray
    voxel_size: float
    shape: tuple[int, int, int]

    @classmethod
    def around(cls, lower: np.ndarray, upper: np.ndarray, voxel_size: float,
               offset: np.ndarray, extra_top: int = 1) -> "VoxelGrid":
        """The grid covering the local box ``[lower, upper]``.

        ``extra_top`` empty layers are added above the data: the paper's
        extra row of empty voxels from which the air is flood-filled.
        """
        if not np.isfinite(voxel_size) or voxel_size <= 0:
            raise UrbanvoxError(f"The voxel size must be a positive number (got {voxel_size}).")
        lower = np.asarray(lower, dtype=np.float64)
        upper = np.asarray(upper, dtype=np.float64)
        counts = np.floor((upper - lower) / voxel_size).astype(np.int64) + 1
        counts[2] += extra_top
        return cls(np.asarray(offset, dtype=np.float64), lower, float(voxel_size),
                   (int(counts[0]), int(counts[1]), int(counts[2])))

    @property
    def n_voxels(self) -> int:
        """Number of voxels ``nx * ny * nz``."""
        return int(np.prod(self.shape, dtype=np.int64))

    def cell_of(self, points: np.ndarray) -> np.ndarray:
        """Integer cell ``(i, j, k)`` of each local point, clipped to the grid.

        The paper takes the ceiling in 1-based numbering; with 0-based cells
        that is the floor of the scaled coordinate.
        """
        ijk = np.floor((points - self.origin) / self.voxel_size).astype(np.int64)
        np.clip(ijk, 0, np.asarray(self.shape) - 1, out=ijk)
        return ijk

    def column_of(self, points: np.ndarray, chunk: int = BIN_CHUNK) -> np.ndarray:
        """Column number ``i * ny + j`` of each local point, ``(i, j)`` as in :meth:`cell_of`.

        From x and y only, a chunk of points at a time: :meth:`cell_of` on
        millions of ground points makes four (N, 3) temporaries, each
        page-faulted afresh (1 s on the 1 km city's 8.7 M ground points, 0.15 s
        this way).

        Examples
        --------
        >>> g = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (4, 3, 2))
        >>> g.column_of(np.array([[0.5, 2.5, 1.2], [3.5, 0.5, 9.0], [-1.0, 9.0, 0.0]])).tolist()
        [2, 9, 2]
        """
        # The same numbers in one pass on all cores (core.grid_kernel).
        found = jit.run("grid_kernel", "column_of", points, self.origin, self.voxel_size, self.shape,
                        size=len(points))
        if found is not None:
            return found
        nx, ny, _ = self.shape
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        upper = np.array([nx - 1, ny - 1], dtype=np.float64)
        column = np.empty(len(points), dtype=np.int64)
        for start in range(0, len(points), chunk):
            # The operations of cell_of, in the same order, so the floors agree bit for bit.
            c = np.floor((points[start:start + chunk, :2] - self.origin[:2]) / self.voxel_size)
            np.clip(c, 0.0, upper, out=c)
            column[start:start + len(c)] = c[:, 0].astype(np.int64) * ny + c[:, 1].astype(np.int64)
        return column

    def voxel_number(self, ijk: np.ndarray) -> np.ndarray:
        """Paper eq. (1): ``i + nx*j + nx*ny*k``."""
        nx, ny, _ = self.shape
        return ijk[:, 0] + nx * (ijk[:, 1] + ny * ijk[:, 2])

    def occupancy(self, points: np.ndarray, chunk: int = BIN_CHUNK) -> np.ndarray:
        """Voxels holding at least one local point, as a boolean ``(nx, ny, nz)`` array.

        The cells are those of :meth:`cell_of` (the same floor and clipping,
        so points on a cell boundary land in the same cell), scattered into a
        flat array indexed by the voxel number. Unlike ``np.unique`` of the
        voxel numbers there is no sort: the cost is a few passes over each
        chunk of points plus one write per point, and the points of a LAS file
        in acquisition order mostly hit voxels already in cache.

        Parameters
        ----------
        points : ndarray of shape (N, 3)
            Local coordinates, finite.
        chunk : int
            Points processed at once.

        Returns
        -------
        ndarray of bool, shape (nx, ny, nz)
            Fortran-ordered, so that ``ravel(order="F")`` is a view indexed by
            the voxel number (eq. 1).

        Examples
        --------
        >>> g = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (4, 3, 2))
        >>> occ = g.occupancy(np.array([[0.5, 2.5, 1.2], [0.7, 2.1, 1.9], [9.0, 0.0, 0.0]]))
        >>> [tuple(int(v) for v in c) for c in np.argwhere(occ)]
        [(0, 2, 1), (3, 0, 0)]
        """
        nx, ny, _ = self.shape
        flat = np.zeros(self.n_voxels, dtype=bool)
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        upper = np.asarray(self.shape, dtype=np.float64) - 1
        # Voxel numbers are computed in float64: exact for integers below 2**53,
        # and one matrix-vector product instead of two integer multiply-adds.
        weights = np.array([1.0, nx, float(nx) * ny])
        cells = np.empty((min(chunk, len(points)), 3))
        number = np.empty(len(cells))
        for start in range(0, len(points), chunk):
            part = points[start:start + chunk]
            c = cells[:len(part)]
            # The operations of cell_of, in the same order, so the floors agree bit for bit.
            np.subtract(part, self.origin, out=c)
            np.divide(c, self.voxel_size, out=c)
            np.floor(c, out=c)
            np.maximum(c, 0.0, out=c)
            np.minimum(c, upper, out=c)
            flat[np.dot(c, weights, out=number[:len(part)]).astype(np.intp)] = True
        return flat.reshape(self.shape, order="F")

    def occupied_cells(self, points: np.ndarray, chunk: int = BIN_CHUNK) -> np.ndarray:
        """Distinct cells ``(i, j, k)`` holding at least one local point.

        The same cells in the same order (by voxel number) as
        ``np.unique(voxel_number(cell_of(points)))``, from :meth:`occupancy`.

        Examples
        --------
        >>> g = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (4, 3, 2))
        >>> g.occupied_cells(np.array([[0.5, 2.5, 1.2], [3.5, 0.5, 0.5], [0.1, 2.9, 1.0]])).tolist()
        [[3, 0, 0], [0, 2, 1]]
        """
        # The same cells through a bitmap per thread, 3-4 times faster (core.grid_kernel).
        found = jit.run("grid_kernel", "occupied_cells", points, self.origin, self.voxel_size, self.shape,
                        size=len(points))
        if found is not None:
            return found
        nx, ny, _ = self.shape
        number = np.flatnonzero(self.occupancy(points, chunk).ravel(order="F"))
        return np.column_stack([number % nx, (number // nx) % ny, number // (nx * ny)])

    def node_xyz(self, number: np.ndarray, nx1: int, ny1: int) -> np.ndarray:
        """Local coordinates (N, 3) of lattice nodes (voxel corners) given by
        their flat numbers ``i + nx1 (j + ny1 k)``, on a lattice ``nx1`` by
        ``ny1`` nodes across (as :func:`core.surface.faces_between` numbers
        them): ``origin + (i, j, k) * voxel_size``.

        In blocks of rows on all cores, each as one pass makes it, without a
        table of every node's (i, j, k) (the 1 km city's 2.3 M surface nodes:
        0.13 s and 55 MB of (i, j, k) on one core).

        Examples
        --------
        >>> grid = VoxelGrid(np.zeros(3), np.array([10.0, 0, 0]), 0.5, (2, 1, 1))  # 3 x 2 x 2 nodes
        >>> grid.node_xyz(np.array([0, 4, 11]), 3, 2).tolist()  # (0, 0, 0), (1, 1, 0), (2, 1, 1)
        [[10.0, 0.0, 0.0], [10.5, 0.5, 0.0], [11.0, 0.5, 0.5]]
        """
        xyz = np.empty((len(number), 3), dtype=np.float64)

        def fill(rows: slice) -> None:
            part = number[rows]
            ijk = np.column_stack([part % nx1, (part // nx1) % ny1, part // (nx1 * ny1)])
            np.add(self.origin, ijk * self.voxel_size, out=xyz[rows])

        map_blocks(fill, balanced_blocks(len(xyz)))
        return xyz

    def column_centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Local x and y of the centres of the ``nx`` by ``ny`` columns."""
        x = self.origin[0] + (np.arange(self.shape[0]) + 0.5) * self.voxel_size
        y = self.origin[1] + (np.arange(self.shape[1]) + 0.5) * self.voxel_size
        return x, y

    def to_world(self, local: np.ndarray) -> np.ndarray:
        """World coordinates of local points."""
        return local + self.offset


@dataclass(frozen=True)
class GridWindow:
    """A box of whole columns of the global lattice, with the grid's full height.

    The single run's grid is one window; a tile's grid (:mod:`core.tiles`) is
    a sub-window of it, so that a voxel has the same place on both lattices.

    Parameters
    ----------
    lower : ndarray of shape (3,)
        World coordinates of the lower corner of the domain's first voxel:
        the offset of local coordinates, shared by all windows of a domain.
    shape : tuple of int
        ``(nx, ny, nz)``, the paper's empty top row included in ``nz``.
    start : tuple of int
        Column ``(i, j)`` of the domain where the window starts.

    Examples
    --------
    >>> pts = np.array([[10.2, 20.7, 3.1], [13.9, 21.0, 9.5]])
    >>> w = GridWindow.around(pts, pts[:0], 1.0)
    >>> w.lower.tolist(), w.shape
    ([10.0, 20.0, 2.0], (4, 2, 9))
    >>> w.columns(1, 0, 3, 2).grid(1.0).origin.tolist()
    [1.0, 0.0, 0.0]
    """

    lower: np.ndarray
    shape: tuple[int, int, int]
    start: tuple[int, int] = (0, 0)

    @classmethod
    def around(cls, ground: np.ndarray, building: np.ndarray, voxel_size: float,
               extent: tuple[float, float, float, float] | None = None) -> "GridWindow":
        """Lattice of multiples of the voxel size covering the points (or the
        extent), with one ground layer under the lowest point and the paper's
        empty top row."""
        h = voxel_size
        lower, upper = bounds([points for points in (ground, building) if len(points)])
        if extent is not None:
            lower[:2] = extent[:2]
            upper[:2] = np.asarray(extent[2:]) - 1e-9 * h  # the last column ends at xmax
        lower = np.floor(lower / h) * h - np.array([0.0, 0.0, h])
        grid = VoxelGrid.around(np.zeros(3), upper - lower, h, offset=lower, extra_top=1)
        return cls(lower, grid.shape)

    def grid(self, voxel_size: float) -> VoxelGrid:
        """The voxel grid of the window.

        Local coordinates are the domain's for every window: the numbers a
        tile computes with are then those of a run on the whole domain.
        """
        origin = np.array([self.start[0], self.start[1], 0]) * float(voxel_size)
        return VoxelGrid(self.lower, origin, float(voxel_size), self.shape)

    def columns(self, i0: int, j0: int, i1: int, j1: int) -> "GridWindow":
        """The sub-window of columns ``i0 <= i < i1``, ``j0 <= j < j1``."""
        return GridWindow(self.lower, (int(i1 - i0), int(j1 - j0), self.shape[2]),
                          (self.start[0] + int(i0), self.start[1] + int(j0)))


def bounds(arrays: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Lowest and highest coordinates of the points of all ``arrays`` (N, 3).

    A block of rows at a time on all cores, one column at a time: numpy's
    reductions along axis 0 of an (N, 3) table run loops three elements long
    (0.4 s on the 1 km city), and one column of all the points strides
    through the whole table (0.09 s for its six columns; 0.04 s so).

    Examples
    --------
    >>> bounds([np.array([[0.0, 5, 1], [2, -1, 3]]), np.array([[-4.0, 0, 9]])])
    (array([-4., -1.,  1.]), array([2., 5., 9.]))
    """
    def extremes(points: np.ndarray, rows: slice) -> list[float]:
        block = points[rows]
        return [block[:, c].min() for c in range(3)] + [block[:, c].max() for c in range(3)]

    found = np.array([part for points in arrays
                      for part in map_blocks(lambda rows, points=points: extremes(points, rows),
                                             row_blocks(len(points), _BOUND_ROWS))])
    return found[:, :3].min(axis=0), found[:, 3:].max(axis=0)


def rounded_up(size: float) -> float:
    """``size`` rounded up to two significant digits (0.1 for sizes of a few
    units): a voxel size to suggest, no smaller than the one that fits."""
    step = 10.0 ** (math.floor(math.log10(size)) - 1) if size > 0 and math.isfinite(size) else 0.1
    return float(math.ceil(size / step) * step) if math.isfinite(size) else size


#: Building points per occupied voxel below which voxels are too small for the data (about 0.55
#: points per voxel on average: half the roof columns see none), and the mean a suggestion aims at.
SPARSE_POINTS_PER_VOXEL, POINTS_PER_VOXEL_WANTED = 1.3, 2.0


def sparse_points_warning(n_points: int, cells: np.ndarray, voxel_size: float) -> str | None:
    """A warning where the ``n_points`` building points are too sparse for
    voxels of ``voxel_size`` metres (``cells``: the voxels they occupy, each
    once), else None.

    Points fall in voxels about as a Poisson count of mean m: the occupied
    ones hold m / (1 - exp(-m)) on average, from which m follows, and a
    fraction exp(-m) of a roof's voxels has no point. On Delft's AHN3 file:
    4.2 points per occupied voxel at 1 m, 1.56 at 0.5 m, 1.13 at 0.35 m,
    1.03 at 0.25 m (where half its blocks break up). The voxel size to
    suggest is scaled from voxels 2, 4, 8... times larger, the first holding
    1.5 points or more (near 1, m is too uncertain to scale from).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> roof = np.column_stack([rng.uniform(0, 40, (2, 4000)).T, np.full(4000, 10.0)])  # 2.5 points per m²
    >>> def cells(h):
    ...     return np.unique(np.floor(roof / h).astype(np.int64), axis=0)
    >>> sparse_points_warning(len(roof), cells(1.0), 1.0) is None
    True
    >>> print(sparse_points_warning(len(roof), cells(0.25), 0.25))
    The building points are sparse for voxels of 0.25 m: about 0.16 per voxel of a roof, so roofs get holes
    and blocks break apart or are dropped. Voxels of at least 0.89 m hold about 2 points each.
    """
    if n_points / len(cells) >= SPARSE_POINTS_PER_VOXEL:
        return None
    first = mean = _poisson_mean(n_points / len(cells))
    factor = 1
    while factor < 64:  # voxels 2, 4, 8... times larger, up to the first that hold 1.5 points each
        factor *= 2
        ratio = n_points / len(np.unique(cells // factor, axis=0))
        mean = _poisson_mean(ratio)
        if ratio >= 1.5:
            break
    suggestion = rounded_up(factor * voxel_size * np.sqrt(POINTS_PER_VOXEL_WANTED / mean))
    return (f"The building points are sparse for voxels of {voxel_size:g} m: about {first:.2f} per voxel of a roof, "
            "so roofs get holes and blocks break apart or are dropped. Voxels of at least "
            f"{suggestion:g} m hold about {POINTS_PER_VOXEL_WANTED:g} points each.")


def _poisson_mean(points_per_occupied: float) -> float:
    """The mean m of a Poisson count whose non-zero values average
    ``points_per_occupied`` = m / (1 - exp(-m)), by bisection (it rises with m).

    Examples
    --------
    >>> round(_poisson_mean(1.0 / (1 - np.exp(-1.0))), 6)
    1.0
    """
    low, high = 1e-9, 100.0
    for _ in range(60):
        mean = 0.5 * (low + high)
        low, high = (mean, high) if mean / -np.expm1(-mean) < points_per_occupied else (low, mean)
    return 0.5 * (low + high)
