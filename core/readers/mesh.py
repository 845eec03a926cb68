"""Read triangle meshes (STL/OBJ/PLY/OFF) and derive the terrain under buildings (paper §2).

The paper accepts "STL files of any quality": CityGML exports are triangle soups
with duplicated vertices, slivers, open edges and edges shared by more than two
triangles where buildings meet. Nothing here needs a clean or closed mesh; the
reader only merges exactly equal vertices and removes triangles that carry no
surface (degenerate or non-finite), because the voxelisation samples the surface.

When no ground is given with a building mesh, :func:`base_points` supplies it:
CityGML buildings stand on the terrain, so the bottoms of their walls trace it.

Example
-------
>>> import tempfile, os, trimesh
>>> path = os.path.join(tempfile.mkdtemp(), "box.stl")
>>> _ = trimesh.creation.box(extents=(10, 10, 6)).export(path)
>>> tris = read_triangles(path)
>>> tris.vertices.shape, tris.faces.shape, tris.n_dropped
((8, 3), (12, 3), 0)
>>> float(base_points(tris, voxel_size=1.0)[:, 2].max())
-3.0
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Callable, List, Optional, Sequence, Tuple

import numpy as np
import scipy.sparse
from scipy.ndimage import minimum_filter
from scipy.sparse.csgraph import connected_components

from ..errors import UrbanvoxError
from ..progress import check_cancel
from ..topology import run_starts, sorted_rows, unique_rows
from ..vectors import finite_rows

__all__ = ["MESH_SUFFIXES", "Triangles", "read_triangles", "clean_triangles", "base_points", "edge_counts"]

MESH_SUFFIXES = (".stl", ".obj", ".ply", ".off")

# base_points rule constants, in metres (converted with ``unit``).
BASE_TOLERANCE_M = 0.10  # minimum height band above a part's lowest z (float32 STL noise)
FLOAT_RADIUS_M = 30.0  # how far to look for lower wall bottoms
FLOAT_RISE_M = 3.0  # a wall bottom may sit this much above the lowest one nearby ...
FLOAT_SLOPE = 0.15  # ... plus 15 % of the horizontal distance (street slopes)
FLOAT_CELL_M = 5.0  # 2D grid cell of the neighbourhood search
_MAX_GRID_CELLS = 8_000_000  # coarsen the grid on huge extents (~200 MB of float64 at most)


@dataclass
class Triangles:
    """A cleaned triangle mesh in world coordinates.

    Attributes
    ----------
    vertices : numpy.ndarray
        (V, 3) float64, exactly equal vertices merged.
    faces : numpy.ndarray
        (F, 3) int64 indices into ``vertices``.
    n_dropped : int
        Triangles removed as degenerate (repeated vertex, zero area) or non-finite.
    warnings : list of str
        Things the user should know but that do not stop the run.
    owner : numpy.ndarray or None
        (F,) for each face, the object of the input it belongs to, as an index
        into ``owner_ids`` (a CityJSON file's buildings); None for a mesh file,
        whose objects are not told apart.
    owner_ids : tuple of str
        The objects' identifiers.
    """

    vertices: np.ndarray
    faces: np.ndarray
    n_dropped: int = 0
    warnings: List[str] = field(default_factory=list)
    owner: Optional[np.ndarray] = None
    owner_ids: Tuple[str, ...] = ()

    def corners(self) -> np.ndarray:
        """(F, 3, 3) corner coordinates: ``corners()[f, i]`` is vertex ``i`` of face ``f``."""
        return self.vertices[self.faces]


def _load(path: str):
    import trimesh  # heavy import, only needed here

    try:
        mesh = trimesh.load(path, force="mesh", process=False)
    except Exception as exc:  # trimesh raises many types (ValueError, KeyError, struct.error, ...)
        raise UrbanvoxError(
            f"{path} cannot be read as a triangle mesh ({type(exc).__name__}: {exc}); check that it is a "
            f"valid {os.path.splitext(path)[1].upper().lstrip('.')} file (e.g. open it in MeshLab or QGIS 3D)."
        ) from exc
    if isinstance(mesh, trimesh.Scene):
        # force="mesh" normally concatenates; older/newer trimesh may still hand back a Scene.
        meshes = mesh.dump() if hasattr(mesh, "dump") else list(mesh.geometry.values())
        meshes = [m for m in meshes if isinstance(m, trimesh.Trimesh) and len(m.faces)]
        mesh = trimesh.util.concatenate(meshes) if meshes else None
    faces = getattr(mesh, "faces", None)
    if mesh is None or faces is None or len(faces) == 0:
        raise UrbanvoxError(
            f"{path} contains no triangles (empty mesh or only points/lines); export the buildings as a "
            "triangulated surface (STL/OBJ/PLY/OFF)."
        )
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)


def _float32_precision_warning(vertices: np.ndarray, path: str) -> Optional[str]:
    """Binary STL stores float32: at projected coordinates (~1e6) that is decimetres."""
    if not path.lower().endswith(".stl") or len(vertices) == 0:
        return None
    if not np.array_equal(vertices.astype(np.float32).astype(np.float64), vertices):
        return None  # ASCII STL with more digits
    step = np.spacing(np.abs(vertices).max(axis=0).astype(np.float32)).astype(np.float64)
    if step.max() < 0.01:
        return None
    return (
        f"{os.path.basename(path)} stores float32 coordinates: near {np.abs(vertices).max():.0f} they are "
        f"rounded to steps of {step[0]:g} (x), {step[1]:g} (y), {step[2]:g} (z) CRS units; export with a local "
        "origin (or as OBJ/PLY with double precision) if this matters at your voxel size."
    )


def read_triangles(path: "str | os.PathLike[str]", is_cancelled: Optional[Callable[[], bool]] = None) -> Triangles:
    """Read a triangle mesh and clean it for sampling.

    Steps: load with trimesh (no processing; a multi-object file is
    concatenated), drop triangles with a non-finite vertex, merge exactly equal
    vertices (an STL is a triangle soup), drop degenerate triangles (two equal
    corners or zero area) and duplicated triangles, and drop unused vertices.

    Parameters
    ----------
    path : str or path-like
        ``.stl``, ``.obj``, ``.ply`` or ``.off`` file in a projected CRS.
    is_cancelled : callable, optional
        Zero-argument callable; True raises :class:`~core.errors.Cancelled`.

    Returns
    -------
    Triangles

    Raises
    ------
    UrbanvoxError
        Missing file, unsupported suffix, unreadable or empty mesh, or no
        triangle left after cleaning.

    Example
    -------
    >>> tris = read_triangles("buildings.stl")  # doctest: +SKIP
    >>> tris.corners().shape  # doctest: +SKIP
    (5142, 3, 3)
    """
    path = os.fspath(path)
    suffix = os.path.splitext(path)[1].lower()
    if suffix not in MESH_SUFFIXES:
        raise UrbanvoxError(
            f"{path}: mesh format '{suffix or 'no suffix'}' is not supported; use one of "
            f"{', '.join(MESH_SUFFIXES)}, or a CityJSON file (.json; convert CityGML to CityJSON, e.g. with "
            "citygml-tools, or to STL first)."
        )
    if not os.path.isfile(path):
        raise UrbanvoxError(f"Mesh file {path} does not exist; check the path.")
    check_cancel(is_cancelled)
    vertices, faces = _load(path)
    check_cancel(is_cancelled)
    return clean_triangles(vertices, faces, path, is_cancelled)


def clean_triangles(vertices: np.ndarray, faces: np.ndarray, path: str,
                    is_cancelled: Optional[Callable[[], bool]] = None,
                    owner: Optional[np.ndarray] = None, owner_ids: Sequence[str] = ()) -> Triangles:
    """The triangles ``faces`` of ``vertices`` read from ``path``, cleaned for
    sampling as :func:`read_triangles` describes (also for the triangles of a
    CityJSON file, :mod:`core.readers.cityjson`). ``owner`` (F,), if given,
    is each face's object (see :class:`Triangles`): the faces kept keep theirs.

    Example
    -------
    >>> vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 0], [2, 0, 0]], float)
    >>> tris = clean_triangles(vertices, np.array([[0, 1, 2], [3, 1, 2], [0, 1, 4]]), "a.obj")
    >>> tris.vertices.tolist(), tris.faces.tolist(), tris.n_dropped
    ([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]], [[0, 2, 1]], 1)
    >>> tris.warnings
    ['dropped 1 degenerate (zero-area) triangles of 3.', 'removed 1 duplicated triangles.']
    """
    n_in = len(faces)
    warnings: List[str] = []
    # The input row of every face kept, for its owner.
    row = np.arange(n_in)

    bad_index = (faces < 0).any(axis=1) | (faces >= len(vertices)).any(axis=1)
    faces, row = faces[~bad_index], row[~bad_index]
    # A triangle with a NaN/inf corner has no usable surface.
    bad_vertex = ~finite_rows(vertices)
    bad_face = bad_vertex[faces].any(axis=1)
    n_nonfinite = int(bad_face.sum()) + int(bad_index.sum())
    faces, row = faces[~bad_face], row[~bad_face]
    if n_nonfinite:
        warnings.append(f"dropped {n_nonfinite} triangles with non-finite or invalid vertices.")

    # Exact merge: "+ 0.0" turns -0.0 into 0.0 so both compare equal row-wise.
    used = np.unique(faces)
    vertices_used, inverse = unique_rows(vertices[used] + 0.0)
    remap = np.zeros(len(vertices), dtype=np.int64)
    remap[used] = inverse
    faces = remap[faces]
    vertices = vertices_used
    check_cancel(is_cancelled)

    # Degenerate: repeated corner, or area negligible against the longest edge
    # (collinear within float64 rounding; such faces carry no surface to sample).
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
    twice_area = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    longest_sq = np.max([((b - a) ** 2).sum(1), ((c - b) ** 2).sum(1), ((a - c) ** 2).sum(1)], axis=0)
    degenerate = repeated | (twice_area <= 1e-9 * longest_sq)
    n_degenerate = int(degenerate.sum())
    faces, row = faces[~degenerate], row[~degenerate]
    if n_degenerate:
        warnings.append(f"dropped {n_degenerate} degenerate (zero-area) triangles of {n_in}.")

    # Duplicated triangles (same three vertices) would only double the samples.
    if len(faces):
        order, starts = sorted_rows(np.sort(faces, axis=1))
        first = order[starts]  # each triangle's first occurrence
        if len(first) < len(faces):
            warnings.append(f"removed {len(faces) - len(first)} duplicated triangles.")
            first = np.sort(first)
            faces, row = faces[first], row[first]

    if len(faces) == 0:
        raise UrbanvoxError(
            f"{path}: all {n_in} triangles are degenerate or non-finite, nothing is left to voxelise; "
            "check the export (units, coordinates) of the mesh."
        )
    used = np.unique(faces)
    if len(used) < len(vertices):  # compact: drop vertices only degenerate faces used
        remap = np.full(len(vertices), -1, dtype=np.int64)
        remap[used] = np.arange(len(used))
        faces, vertices = remap[faces], vertices[used]

    note = _float32_precision_warning(vertices, path)
    if note:
        warnings.append(note)
    return Triangles(vertices=vertices, faces=faces, n_dropped=n_nonfinite + n_degenerate, warnings=warnings,
                     owner=None if owner is None else np.asarray(owner).take(row), owner_ids=tuple(owner_ids))


def edge_counts(tris: Triangles) -> Tuple[int, int]:
    """Count open edges (one triangle) and non-manifold edges (more than two triangles).

    Informative only: the voxel method does not need a closed or manifold mesh.

    Example
    -------
    >>> import trimesh
    >>> box = trimesh.creation.box()
    >>> edge_counts(Triangles(box.vertices, box.faces))
    (0, 0)
    >>> edge_counts(Triangles(box.vertices, box.faces[:-1]))
    (3, 0)
    """
    edges = np.sort(tris.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return int((counts == 1).sum()), int((counts > 2).sum())


def _part_minimum(labels: np.ndarray, z: np.ndarray, n_parts: int) -> np.ndarray:
    """Lowest z of every connected part (sort-based, no Python loop)."""
    order = np.lexsort((z, labels))
    ordered = labels[order]
    first = run_starts(ordered)
    low = np.full(n_parts, np.inf)
    low[ordered[first]] = z[order][first]
    return low


def _not_floating(points: np.ndarray, unit: float) -> np.ndarray:
    """Mask of candidates not floating above lower candidates nearby (see :func:`base_points`)."""
    xy0 = points[:, :2].min(axis=0)
    extent = points[:, :2].max(axis=0) - xy0
    cell = max(FLOAT_CELL_M / unit, float(np.sqrt((extent[0] + 1) * (extent[1] + 1) / _MAX_GRID_CELLS)))
    ij = np.floor((points[:, :2] - xy0) / cell).astype(np.int64)
    shape = tuple(ij.max(axis=0) + 1)
    flat = np.ravel_multi_index((ij[:, 0], ij[:, 1]), shape)
    cell_low = np.full(shape, np.inf)
    order = np.lexsort((points[:, 2], flat))
    ordered = flat[order]
    first = run_starts(ordered)
    cell_low.flat[ordered[first]] = points[order, 2][first]
    # Ring k covers cells within k of the candidate's cell: horizontal distance
    # below (k + 1) * cell. The allowed height grows with that distance.
    rings = max(1, int(np.ceil(FLOAT_RADIUS_M / unit / cell)))
    allowed = np.full(shape, np.inf)
    for k in range(rings):
        low_k = minimum_filter(cell_low, size=2 * k + 1, mode="constant", cval=np.inf)
        allowed = np.minimum(allowed, low_k + (FLOAT_RISE_M / unit + FLOAT_SLOPE * (k + 1) * cell))
    return points[:, 2] <= allowed.flat[flat]


def _densify_edges(vertices: np.ndarray, edges: np.ndarray, step: float) -> np.ndarray:
    """Points every <= ``step`` along ``edges`` (end points excluded)."""
    a, b = vertices[edges[:, 0]], vertices[edges[:, 1]]
    n = np.maximum(1, np.ceil(np.linalg.norm(b - a, axis=1) / step)).astype(np.int64)
    inner = n - 1
    total = int(inner.sum())
    if total == 0:
        return np.empty((0, 3))
    edge = np.repeat(np.arange(len(edges)), inner)
    starts = np.cumsum(inner) - inner
    i = np.arange(total) - np.repeat(starts, inner) + 1
    t = (i / n[edge])[:, None]
    return a[edge] + t * (b[edge] - a[edge])


def base_points(tris: Triangles, voxel_size: float, unit: float = 1.0) -> np.ndarray:
    """Terrain points under a building mesh: the bottoms of the walls.

    Rule (used when no ground is given with a CityGML-derived building mesh,
    whose buildings stand on the terrain):

    1. Split the mesh into connected parts (vertices linked through faces).
    2. In each part, the candidates are the vertices within
       ``max(0.1 m, 0.25 * voxel_size)`` of the part's lowest z (wall bottoms).
    3. Drop candidates that float above lower candidates nearby (a dormer or roof
       that is its own part): keep a candidate only if its z is at most
       ``min z of the candidates within d + 3 m + 0.15 * d`` for every ring
       distance d = 5, 10, ..., 30 m (evaluated on a 5 m grid of minimum z with
       ``scipy.ndimage.minimum_filter``, so d is rounded up to the ring).
    4. Densify: along every face edge whose two ends are kept candidates (wall
       bottoms, footprint outline), add points every <= ``voxel_size / 2`` so the
       interpolated ground follows the footprint.

    Parameters
    ----------
    tris : Triangles
        Building mesh.
    voxel_size : float
        Voxel edge length in CRS units.
    unit : float, default 1.0
        Metres per CRS unit (:func:`core.crs.metres_per_unit`), for the metre constants.

    Returns
    -------
    numpy.ndarray
        (G, 3) float64 world coordinates, unique rows.

    Example
    -------
    >>> import trimesh
    >>> house = trimesh.creation.box(extents=(10, 10, 6)); _ = house.apply_translation((0, 0, 3))
    >>> dormer = trimesh.creation.box(extents=(2, 2, 2)); _ = dormer.apply_translation((0, 0, 7))
    >>> both = trimesh.util.concatenate([house, dormer])
    >>> g = base_points(Triangles(both.vertices, both.faces), voxel_size=1.0)
    >>> float(g[:, 2].min()), float(g[:, 2].max()), len(g) > 8
    (0.0, 0.0, True)
    """
    if not voxel_size > 0:
        raise UrbanvoxError(f"The voxel size must be positive (got {voxel_size}).")
    vertices = np.asarray(tris.vertices, dtype=np.float64)
    faces = np.asarray(tris.faces, dtype=np.int64)
    if len(faces) == 0:
        return np.empty((0, 3))
    rows = faces[:, [0, 1, 2]].ravel()
    cols = faces[:, [1, 2, 0]].ravel()
    graph = scipy.sparse.coo_matrix(
        (np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(len(vertices), len(vertices))
    ).tocsr()
    n_parts, labels = connected_components(graph, directed=False)
    z = vertices[:, 2]
    low = _part_minimum(labels, z, n_parts)
    tolerance = max(BASE_TOLERANCE_M / unit, 0.25 * voxel_size)
    used = np.zeros(len(vertices), dtype=bool)
    used[faces.ravel()] = True  # isolated vertices are not wall bottoms
    candidate = used & (z - low[labels] <= tolerance)

    index = np.flatnonzero(candidate)
    keep = np.zeros(len(vertices), dtype=bool)
    keep[index[_not_floating(vertices[index], unit)]] = True

    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    edges = unique_rows(edges[keep[edges].all(axis=1)])[0]
    extra = _densify_edges(vertices, edges, voxel_size / 2.0)
    return unique_rows(np.vstack([vertices[keep], extra]))[0]
