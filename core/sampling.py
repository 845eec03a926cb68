"""Turn triangles into points no farther apart than a given spacing (paper §2).

"If a STL file is provided, triangles are discretized using the finite element
shape functions so that the maximal space between neighbouring points does not
exceed 10% of the chosen voxel size." A triangle whose longest edge is L is
refined ``n = ceil(L / spacing)`` times; its points are the nodes of that
refinement, i.e. the images of the barycentric lattice
``(a/n, b/n, 1 - a/n - b/n)``, ``a + b <= n``, through the P1 shape functions.
Neighbouring nodes lie on segments parallel to the edges, at most ``L / n <=
spacing`` apart. A triangle gives ``(n + 1)(n + 2) / 2`` points, vertices and
edges included; points on shared edges are repeated (harmless for voxelisation).

Triangles are grouped by ``n``; each group's lattice is built once and applied
to all its triangles with one batched matrix product. Output is produced in chunks of about
``chunk_points`` points so memory stays bounded.

Example
-------
>>> tri = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]])
>>> sample_triangles(tri, spacing=0.5).shape  # n = ceil(1.414 / 0.5) = 3 -> 10 points
(10, 3)
>>> estimate_sample_count(tri, 0.5)
10
"""

from __future__ import annotations

from typing import Callable, Iterator

import numpy as np

from . import jit
from .errors import Cancelled, UrbanvoxError
from .memory import memory_error
from .topology import run_starts, sorted_unique

#: Bytes per point of :func:`sample_thinned` while its chunks' cells are merged
#: (the cells' keys, sums and counts, their sort, the means).
THINNED_POINT_BYTES = 80

__all__ = ["refinement", "lattice", "estimate_sample_count", "iter_sample_triangles", "sample_triangles",
           "sample_thinned"]


def _check(corners: np.ndarray, spacing: float) -> np.ndarray:
    corners = np.asarray(corners, dtype=np.float64)
    if corners.ndim != 3 or corners.shape[1:] != (3, 3):
        raise ValueError(f"corners must have shape (F, 3, 3), got {corners.shape}")
    if not (np.isfinite(spacing) and spacing > 0):
        raise UrbanvoxError(f"The sampling spacing must be a positive number (got {spacing}); check the voxel size.")
    return corners


def refinement(corners: np.ndarray, spacing: float) -> np.ndarray:
    """Refinement level ``n = max(1, ceil(longest_edge / spacing))`` of every triangle.

    Example
    -------
    >>> refinement(np.array([[[0.0, 0, 0], [3, 0, 0], [0, 4, 0]]]), 1.0)
    array([5])
    """
    corners = _check(corners, spacing)
    edges = corners[:, [1, 2, 0]] - corners  # (F, 3, 3): b-a, c-b, a-c
    longest = np.sqrt((edges**2).sum(axis=2).max(axis=1))
    if not np.isfinite(longest).all():
        raise UrbanvoxError("Some triangles have non-finite coordinates; read the mesh with read_triangles first.")
    # The tiny relative slack avoids an extra level when L / spacing is an
    # integer up to rounding (e.g. 1.0000000000000002).
    return np.maximum(1, np.ceil(longest / spacing * (1 - 1e-12))).astype(np.int64)


def lattice(n: int) -> np.ndarray:
    """Barycentric weights of the ``n``-refined P1 lattice, shape ((n+1)(n+2)/2, 3).

    Example
    -------
    >>> lattice(1)
    array([[0., 0., 1.],
           [0., 1., 0.],
           [1., 0., 0.]])
    """
    return lattice_rows(n, 0, n + 1)


def lattice_rows(n: int, first: int, stop: int) -> np.ndarray:
    """The rows ``first <= a < stop`` of :func:`lattice(n) <lattice>`, in its order.

    Example
    -------
    >>> lattice_rows(2, 1, 3).tolist() == lattice(2)[3:].tolist()
    True
    """
    rows = np.arange(first, stop)
    lengths = n + 1 - rows  # b = 0 .. n - a
    a = np.repeat(rows, lengths)
    b = np.arange(len(a)) - np.repeat(np.cumsum(lengths) - lengths, lengths)
    return np.stack([a, b, n - a - b], axis=1).astype(np.float64) / n


def estimate_sample_count(corners: np.ndarray, spacing: float) -> int:
    """Number of points :func:`sample_triangles` will produce (for a memory check).

    Each point costs 24 bytes (3 float64) in the output.

    Example
    -------
    >>> estimate_sample_count(np.array([[[0.0, 0, 0], [3, 0, 0], [0, 4, 0]]]), 1.0)  # n = 5
    21
    """
    corners = _check(corners, spacing)
    if len(corners) == 0:
        return 0
    n = refinement(corners, spacing).astype(np.float64)  # float: n**2 may overflow int64
    return int(round(float((0.5 * (n + 1) * (n + 2)).sum())))


def iter_sample_triangles(corners: np.ndarray, spacing: float, chunk_points: int = 5_000_000) -> Iterator[np.ndarray]:
    """Yield (k, 3) float64 point arrays of about ``chunk_points`` points each.

    Same points as :func:`sample_triangles`, for callers that bin points into
    voxels chunk by chunk and never hold all of them.

    Example
    -------
    >>> tri = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]] * 4)
    >>> [len(c) for c in iter_sample_triangles(tri, 0.5, chunk_points=25)]
    [20, 20]
    """
    corners = _check(corners, spacing)
    if len(corners) == 0:
        return
    n = refinement(corners, spacing)
    levels, group = np.unique(n, return_inverse=True)
    order = np.argsort(group, kind="stable")
    bounds = np.searchsorted(group[order], np.arange(len(levels) + 1))
    for g, level in enumerate(levels):
        members = order[bounds[g] : bounds[g + 1]]
        if (level + 1) * (level + 2) // 2 > chunk_points:
            # One triangle's lattice is more than a chunk (a ground of two
            # triangles a kilometre wide: 10^8 points at 1 m voxels): its
            # points in bands of rows, the same points in the same order.
            rows = max(1, int(chunk_points) // (int(level) + 1))
            for triangle in members:
                for first in range(0, int(level) + 1, rows):
                    weights = lattice_rows(int(level), first, min(first + rows, int(level) + 1))
                    yield np.matmul(weights, corners[triangle : triangle + 1]).reshape(-1, 3)
            continue
        weights = lattice(int(level))
        per_chunk = max(1, int(chunk_points) // len(weights))
        for start in range(0, len(members), per_chunk):
            tri = corners[members[start : start + per_chunk]]
            # (m, 3) weights @ (k, 3, 3) corners -> (k, m, 3): P1 interpolation
            # (same as einsum "mj,kjd->kmd", but matmul uses BLAS: ~10x faster).
            yield np.matmul(weights, tri).reshape(-1, 3)


def sample_triangles(corners: np.ndarray, spacing: float, chunk_points: int = 5_000_000) -> np.ndarray:
    """Sample triangles with neighbouring points at most ``spacing`` apart.

    Parameters
    ----------
    corners : numpy.ndarray
        (F, 3, 3) triangle corners (:meth:`Triangles.corners`), finite.
    spacing : float
        Maximum distance between neighbouring points; the pipeline passes
        ``0.1 * voxel_size`` (paper §2).
    chunk_points : int
        Points computed per vectorised step (bounds the temporary memory).

    Returns
    -------
    numpy.ndarray
        (N, 3) float64 points, N = :func:`estimate_sample_count`. Vertices and
        edge points are included.

    Example
    -------
    >>> tri = np.array([[[0.0, 0, 0], [2, 0, 0], [0, 2, 0]]])
    >>> pts = sample_triangles(tri, spacing=1.0)  # n = 3
    >>> len(pts), pts.min(axis=0).tolist(), pts.max(axis=0).tolist()
    (10, [0.0, 0.0, 0.0], [2.0, 2.0, 0.0])
    """
    corners = _check(corners, spacing)
    total = estimate_sample_count(corners, spacing)
    out = np.empty((total, 3), dtype=np.float64)
    filled = 0
    for part in iter_sample_triangles(corners, spacing, chunk_points):
        out[filled : filled + len(part)] = part
        filled += len(part)
    assert filled == total
    return out


def sample_thinned(corners: np.ndarray, spacing: float, cell: float,
                   is_cancelled: Callable[[], bool] | None = None,
                   chunk_points: int = 5_000_000,
                   progress: Callable[[float, str], None] | None = None) -> np.ndarray:
    """Sample triangles, keeping one point (the mean) per occupied ``cell`` cube.

    The cubes lie on the world lattice of multiples of ``cell``; when ``cell``
    divides the voxel size (the pipeline uses a third of it) every cube sits
    inside one voxel, so the voxel occupancy is exactly that of the full
    sample, at a fraction of its memory: the full sample of a city mesh at
    10 % of a voxel is tens of millions of points, held here one chunk at a time.
    ``progress(fraction, message)`` is told the share of the samples made
    after each chunk.

    Examples
    --------
    >>> tri = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]])
    >>> len(sample_triangles(tri, 0.1)), len(sample_thinned(tri, 0.1, 0.5))
    (136, 5)
    """
    corners = _check(corners, spacing)
    if len(corners) == 0:
        return np.zeros((0, 3))
    low = np.floor(corners.reshape(-1, 3).min(axis=0) / cell).astype(np.int64)
    span = np.floor(corners.reshape(-1, 3).max(axis=0) / cell).astype(np.int64) - low + 1
    if np.any(span >= 2**21):
        raise UrbanvoxError(f"The mesh spans {float(span.max() * cell):.4g} units, more than 2^21 sample cells of "
                            f"{cell:.4g} (a third of a voxel): use a larger voxel size, or split the mesh.")
    parts = []
    # The work is all the samples, however the chunks cut it: the compiled
    # pass (core.jit) loads for many samples from the first chunk on.
    work = estimate_sample_count(corners, spacing)
    done = 0
    for chunk in iter_sample_triangles(corners, spacing, chunk_points):
        if is_cancelled is not None and is_cancelled():
            raise Cancelled()
        parts.append(_cell_means(chunk, cell, low, work))
        done += len(chunk)
        if progress is not None:
            progress(done / work, "Sampling triangles")
    keys = np.concatenate([p[0] for p in parts])
    sums = np.concatenate([p[1] for p in parts])
    counts = np.concatenate([p[2] for p in parts])
    unique, inverse = sorted_unique(keys, return_inverse=True)
    total = np.bincount(inverse, weights=counts)
    merged = np.column_stack([np.bincount(inverse, weights=sums[:, c]) for c in range(3)])
    return merged / total[:, None]


def check_sample_memory(area: float, cell: float, voxel_size: float, available: int, unit: float = 1.0) -> int:
    """Estimate the bytes of :func:`sample_thinned`'s points in cells of side
    ``cell`` over triangles of ``area`` (coordinate units², ``unit`` metres
    each: :func:`core.topology.surface_area`); refuse before sampling if more
    than ``available``, with the voxel size (``voxel_size``, in metres) that fits.

    A surface of area A fills at least A / (1.5 cell^2) cells of side ``cell``
    (a plane cuts a cube in at most 1.3 of its face's area): a point each,
    :data:`THINNED_POINT_BYTES` bytes while the chunks' cells are merged.
    A voxel far too small for the mesh (a 20 m box at 1 mm: 10^10 points)
    stops here, before the samples' hours of work, not at the grid's guard
    after them.

    Examples
    --------
    >>> check_sample_memory(200.0, 1 / 3, 1.0, available=10**9)
    96000
    >>> try:
    ...     check_sample_memory(200.0, 1e-3 / 3, 1e-3, available=10**9)
    ... except UrbanvoxError as error:
    ...     print(error)
    Sampling the mesh's 200 m² of surface at a voxel size of 0.001 needs about 89.4 GiB
    but only 0.93 GiB is available. Use a voxel size of at least 0.011, or a smaller area.
    """
    if not (np.isfinite(cell) and cell > 0):
        return 0  # the voxel size is refused with its own message
    needed = int(area / (1.5 * cell**2) * THINNED_POINT_BYTES)
    if needed > available:
        raise memory_error(f"Sampling the mesh's {area * unit**2:.0f} m² of surface at a voxel size of {voxel_size:g}",
                           needed, available, voxel_size, 2)
    return needed


def _cell_means(points: np.ndarray, cell: float, low: np.ndarray, work: int):
    """The cells of ``points`` (sorted numbers), and the sums of the coordinates
    and the numbers of the points in each; ``work``, the samples of the whole
    sampling (:func:`core.jit.kernels`)."""
    # Points sampled along a triangle's rows fall in the same cell several
    # times in a row (5.4 on average on the Zurich mesh at 0.5 m): only the
    # runs' keys are sorted (a stable sort, which takes runs fast), and the
    # runs then hand their number to their points. The same cells and
    # inverse as np.unique(key, return_inverse=True), 2.4 times faster.
    # Compiled, the keys and their runs in one pass, the sums in another
    # (core.sampling_kernel): the same numbers.
    found = jit.run("sampling_kernel", "cell_runs", points, cell, low, size=work)
    if found is not None:
        run_keys, starts = found
    else:
        # One coordinate at a time (no (N, 3) temporaries).
        ijk = [np.floor(points[:, c] / cell).astype(np.int64) - low[c] for c in range(3)]
        key = ijk[0] | (ijk[1] << 21) | (ijk[2] << 42)
        del ijk
        starts = np.flatnonzero(run_starts(key))
        run_keys = key[starts]
        del key
    unique, run_inverse = sorted_unique(run_keys, return_inverse=True)
    found = jit.run("sampling_kernel", "run_sums", points, starts, run_inverse, len(unique), size=work)
    if found is not None:
        sums, counts = found
        return unique, sums, counts
    inverse = np.repeat(run_inverse, np.diff(np.append(starts, len(points))))
    counts = np.bincount(inverse).astype(np.float64)
    sums = np.column_stack([np.bincount(inverse, weights=points[:, c]) for c in range(3)])
    return unique, sums, counts
