"""The memory guard: a run's memory estimated before it allocates, and
refused, with what would fit, where the machine does not have it.

The grid's voxels and the points (:func:`check_memory`, before the grid
exists), a tiled run's domain-wide columns (:func:`check_column_memory`)
and the surfaces' faces once they are counted (:func:`check_face_memory`),
each against the memory available to the process (:func:`available_memory`).
A refusal gives the estimate, the voxel size that fits and, where tiles
help, the tile size (:mod:`core.tiles`).
"""
from __future__ import annotations

import math

import numpy as np

from . import jit
from .errors import UrbanvoxError
from .grid import rounded_up
from .heap import held_free_bytes, proc_bytes

#: Bytes per voxel the voxel stages hold at once with numpy's code: labels
#: (uint8), boolean masks, the int32 output of scipy.ndimage.label and the
#: int32 regions the faces are read from, and the faces the surfaces'
#: extraction makes before their own check (:func:`check_face_memory`).
#: Measured (live arrays, the 1 km synthetic city): 11.1 B at 1 m and 0.5 m
#: in the voxel stages, 14.0 B at 1 m with the extraction's faces.
BYTES_PER_VOXEL = 16
#: The same with the compiled kernels (:mod:`core.jit`), which label in
#: place and scan the grid without masks of it: measured 6.7 B at 1 m and
#: 5.3 B at 0.5 m in the voxel stages, 10.4 B and 6.7 B with the
#: extraction's faces (at coarser voxels the faces weigh more per voxel;
#: the points' term covers them at 2 m).
BYTES_PER_VOXEL_COMPILED = 10
#: Bytes per point (ground and building) the run adds to the points given:
#: their copy in the grid's local coordinates, the ground level's tables,
#: the classes' per-point arrays. Measured on the same city: 50 B at 2 m,
#: where the ground level's tables are the run's peak before the surfaces.
BYTES_PER_POINT = 48
#: Bytes per column of the domain-wide 2-D fields of a tiled run (the ground
#: level: heights, top cells, flags and the gap fill's temporaries).
BYTES_PER_COLUMN = 64
#: Fewest voxels across a tile worth suggesting (a halo of a few voxels each side).
_SMALLEST_TILE_VOXELS = 64


def voxel_bytes(n_voxels: int) -> int:
    """Bytes per voxel of a grid of ``n_voxels`` for the memory guard: the
    compiled kernels' figure where they will run on it (:func:`core.jit.expected`),
    else numpy's.

    Examples
    --------
    >>> import os
    >>> before = os.environ.get("URBANVOX_JIT")
    >>> os.environ["URBANVOX_JIT"] = "0"  # the kernels switched off
    >>> voxel_bytes(10**9)
    16
    >>> _ = os.environ.pop("URBANVOX_JIT") if before is None else os.environ.update(URBANVOX_JIT=before)
    """
    return BYTES_PER_VOXEL_COMPILED if jit.expected(n_voxels) else BYTES_PER_VOXEL


def check_memory(shape: tuple[int, int, int], voxel_size: float, available: int | None = None,
                 bytes_per_voxel: int = BYTES_PER_VOXEL, tile_hint: bool = False, points: int = 0) -> int:
    """Estimate the bytes a grid needs; refuse it before allocating if too large.

    Parameters
    ----------
    shape : tuple of int
        Grid shape ``(nx, ny, nz)``.
    voxel_size : float
        For the message: the voxel size that would fit is suggested.
    available : int, optional
        Bytes the run may use; default: the machine's available memory.
    bytes_per_voxel : int
        :data:`BYTES_PER_VOXEL`, or :func:`voxel_bytes` for the path the run takes.
    tile_hint : bool
        Also suggest the tile size (:mod:`core.tiles`) whose grids fit.
    points : int
        The points the run voxelises: :data:`BYTES_PER_POINT` each, at any voxel size.

    Returns
    -------
    int
        The estimate in bytes.

    Examples
    --------
    >>> check_memory((100, 100, 50), 1.0, available=10**9)
    8000000
    >>> try:
    ...     check_memory((10**4, 10**4, 200), 0.5, available=10**9)
    ... except UrbanvoxError as error:
    ...     print(error)
    The voxel grid (10000 x 10000 x 200 = 20000000000 voxels at 0.5) needs about 298.0 GiB
    but only 0.93 GiB is available. Use a voxel size of at least 3.6, or a smaller area.
    >>> try:
    ...     check_memory((100, 100, 50), 1.0, available=10**9, points=10**8)
    ... except UrbanvoxError as error:
    ...     print(error)
    The voxel grid (100 x 100 x 50 = 500000 voxels at 1) with its 100000000 points needs about 4.5 GiB
    but only 0.93 GiB is available. The points alone need 4.5 GiB: use a smaller area.
    """
    n = math.prod(int(side) for side in shape)  # Python's integers: a tiny voxel's count overflows int64
    for_points = int(points) * BYTES_PER_POINT
    needed = n * bytes_per_voxel + for_points
    if available is None:
        available = available_memory()
    if not available > 0:  # a max_memory of 0 or NaN given to the core
        raise UrbanvoxError(f"The memory a run may use must be a positive number of bytes (got {available}).")
    if needed > available:
        what = f"The voxel grid ({shape[0]} x {shape[1]} x {shape[2]} = {n} voxels at {voxel_size:g})"
        if points:
            what += f" with its {int(points)} points"
        # Tiles help only where they are more than a halo wide and the domain's
        # 2-D fields (core.tiles) fit.
        per_column = bytes_per_voxel * shape[2] + for_points / max(shape[0] * shape[1], 1)
        tile = _fitting_tile(per_column, voxel_size, available)
        tiles_fit = tile >= _SMALLEST_TILE_VOXELS * voxel_size \
            and shape[0] * shape[1] * BYTES_PER_COLUMN <= available
        end = f", or tiles of at most {tile:g} (TILE_SIZE)." if tile_hint and tiles_fit else "."
        # Voxel count scales with 1/size^3 (2-D extent) or at least 1/size^2:
        # the cube-root scaling is suggested, for what the points leave; where
        # even that grid would not fit beside them, no voxel size helps.
        size = fitting_voxel_size(needed, available, voxel_size, 3, fixed=for_points)
        coarser = math.prod(max(1, math.ceil(int(side) * voxel_size / size)) for side in shape)
        if coarser * bytes_per_voxel + for_points > available:
            raise UrbanvoxError(f"{what} needs about {_gib(needed)} GiB but only {_gib(available)} GiB is "
                                f"available. The points alone need {_gib(for_points)} GiB: use a smaller area"
                                f"{end}")
        raise memory_error(what, needed, available, voxel_size, 3, end, fixed=for_points)
    return needed


def fitting_voxel_size(needed: int, available: int, voxel_size: float, dimensions: int, fixed: int = 0) -> float:
    """The voxel size at which ``needed`` bytes of ``voxel_size`` fit in
    ``available``, where the bytes beyond ``fixed`` scale with
    1/size^``dimensions`` (rounded up, 5 % to spare); ``inf`` where ``fixed``
    alone takes ``available``.

    Examples
    --------
    >>> fitting_voxel_size(8 * 2**30, 2**30, 0.5, 3)
    1.1
    """
    if fixed >= available:
        return math.inf
    return rounded_up(voxel_size * ((needed - fixed) / (available - fixed)) ** (1.0 / dimensions) * 1.05)


def memory_error(what: str, needed: int, available: int, voxel_size: float, dimensions: int,
                 end: str = ".", fixed: int = 0) -> UrbanvoxError:
    """The error for ``what`` needing ``needed`` bytes of ``available``: the
    estimate, and the voxel size that fits (:func:`fitting_voxel_size`), then ``end``.

    Examples
    --------
    >>> print(memory_error("The grid", 8 * 2**30, 2**30, 0.5, 3))
    The grid needs about 8.0 GiB but only 1.0 GiB is available. Use a voxel size of at least 1.1, or a smaller area.
    """
    suggestion = fitting_voxel_size(needed, available, voxel_size, dimensions, fixed)
    return UrbanvoxError(f"{what} needs about {_gib(needed)} GiB but only {_gib(available)} GiB is available. "
                         f"Use a voxel size of at least {suggestion:g}, or a smaller area{end}")


def _gib(size: int) -> str:
    """Bytes in GiB, with two decimals below one."""
    return f"{size / 2**30:.{1 if size >= 2**30 else 2}f}"


def check_column_memory(shape: tuple[int, int], voxel_size: float, available: int | None = None) -> int:
    """Estimate the bytes of a tiled run's domain-wide 2-D fields (nx x ny
    columns); refuse them before allocating if too large, with the voxel size
    that fits (the columns scale with 1/size^2).

    Examples
    --------
    >>> check_column_memory((1000, 1000), 1.0, available=10**9)
    64000000
    >>> try:
    ...     check_column_memory((10**6, 10**6), 1.0, available=10**9)
    ... except UrbanvoxError as error:
    ...     print(error)
    The ground level of the domain's 1000000 x 1000000 columns at 1 needs about 59604.6 GiB
    but only 0.93 GiB is available. Use a voxel size of at least 270, or a smaller area.
    """
    needed = math.prod(int(side) for side in shape) * BYTES_PER_COLUMN
    if available is None:
        available = available_memory()
    if needed > available:
        raise memory_error(f"The ground level of the domain's {shape[0]} x {shape[1]} columns at {voxel_size:g}",
                           needed, available, voxel_size, 2)
    return needed


def available_memory() -> int:
    """Bytes of memory available to this process: the system's
    (Linux ``MemAvailable``) and what the process's heaps hold free for its
    next arrays (:func:`core.heap.held_free_bytes`: a run's freed memory,
    kept for the next step and the next run, which ``MemAvailable`` leaves out)."""
    return _system_available() + held_free_bytes()


def _system_available() -> int:
    """The system's available memory in bytes (``MemAvailable``); 8 GiB where unknown."""
    found = proc_bytes("/proc/meminfo", "MemAvailable")
    return 8 * 2**30 if found is None else found


#: Bytes per surface face (quad) that the surfaces, smoothing, projection and
#: the measures add: node and face arrays, the triangles of the best splits,
#: the smoothing's tables, the projection's searches. Measured on the 1 km
#: synthetic city at 1 m (benchmarks/run.py) in an early round: peak RSS
#: 2.16 GB before the surfaces, 3.35 GB after the projection, for 4.85 M faces
#: (245 B per face), with a margin. That run's whole peak is 1.85 GB now: the
#: estimate errs on the safe side.
BYTES_PER_FACE = 400


def check_face_memory(n_faces: int, n_columns: int, voxel_size: float, available: int | None = None,
                      bytes_per_face: int = BYTES_PER_FACE) -> int:
    """Estimate the bytes the surface stages need; refuse them before they allocate.

    The voxel grid is checked by :func:`check_memory` before it exists; the
    number of faces is known only once the surfaces are extracted, and a
    city's surfaces can need more memory than its grid.

    Examples
    --------
    >>> check_face_memory(10**6, 10**6, 1.0, available=8 * 2**30)
    400000000
    >>> try:
    ...     check_face_memory(2 * 10**8, 4 * 10**6, 1.0, available=8 * 2**30)
    ... except UrbanvoxError as error:
    ...     print(error)
    The surfaces (200000000 faces) need about 74.5 GiB for smoothing and projection but only
    8.0 GiB is available. Use a voxel size of at least 3.3, or tiles of at most 458 (TILE_SIZE).
    """
    needed = int(n_faces) * bytes_per_face
    if available is None:
        available = available_memory()
    if needed > available:
        factor = np.sqrt(needed / available)  # faces scale with 1 / size²
        suggestion = np.ceil(voxel_size * factor * 1.05 * 10) / 10
        per_column = n_faces / max(n_columns, 1)
        side = np.floor(0.7 * np.sqrt(available / (bytes_per_face * per_column)))
        raise UrbanvoxError(
            f"The surfaces ({n_faces} faces) need about {needed / 2**30:.1f} GiB for smoothing and projection "
            f"but only {available / 2**30:.1f} GiB is available. Use a voxel size of at least {suggestion:g}, "
            f"or tiles of at most {max(1.0, side) * voxel_size:g} (TILE_SIZE).")
    return needed


def _fitting_tile(per_column: float, voxel_size: float, available: int) -> float:
    """Side of the square tile whose grid and points, halo included, fit in
    ``available``, at ``per_column`` bytes a column of voxels."""
    side = np.sqrt(available / per_column)  # voxels, halo included
    return float(max(1.0, np.floor(0.7 * side)) * voxel_size)
