"""Read CityJSON city models: the buildings' surfaces as triangles, the terrain, the CRS.

The building meshes the paper voxelises (§2) come from CityGML; CityJSON is its
JSON encoding, in which many LoD2 models are delivered (3D BAG, cities' open
data). A city object's geometry is a set of planar polygons, some with holes,
that need not close a volume, with overlaps where parts meet: the quality the
method was made for. So the polygons are triangulated and handed to the mesh
method like any building mesh (:func:`core.readers.mesh.clean_triangles`).

- Buildings: the objects of type ``Building``, ``BuildingPart`` and
  ``BuildingInstallation``, each with its geometries of the highest LoD it has,
  or of the LoD asked for where it has that one (3D BAG has 1.2, 1.3 and 2.2:
  a simpler model for a coarser mesh).
- Terrain: the ``TINRelief`` objects, if there are any: the ground when no
  ground mesh is given.
- CRS: ``metadata.referenceSystem`` (an OGC URL or URN such as
  ``https://www.opengis.net/def/crs/EPSG/0/7415``); a file without it needs
  the CRS parameter, like an STL.

A CityJSON Sequence (``.jsonl``, as 3D BAG's API and ``cjio`` export them) is
read the same: its first line holds the transform and the metadata, every
other line a feature (a building) with vertices of its own.

Other objects (roads, vegetation, water...) and geometry templates are left
out, with a warning that counts them.

Example
-------
>>> import json, os, tempfile
>>> box = {"type": "CityJSON", "version": "2.0",
...        "transform": {"scale": [0.01, 0.01, 0.01], "translate": [1000.0, 2000.0, 0.0]},
...        "metadata": {"referenceSystem": "https://www.opengis.net/def/crs/EPSG/0/2056"},
...        "vertices": [[0, 0, 0], [1000, 0, 0], [1000, 800, 0], [0, 800, 0],
...                     [0, 0, 600], [1000, 0, 600], [1000, 800, 600], [0, 800, 600]],
...        "CityObjects": {"b1": {"type": "Building", "geometry": [{"type": "Solid", "lod": "2.2",
...            "boundaries": [[[[0, 3, 2, 1]], [[4, 5, 6, 7]], [[0, 1, 5, 4]], [[1, 2, 6, 5]],
...                            [[2, 3, 7, 6]], [[3, 0, 4, 7]]]]}]}}}
>>> path = os.path.join(tempfile.mkdtemp(), "box.city.json")
>>> with open(path, "w") as f:
...     json.dump(box, f)
>>> city = read_cityjson(path)
>>> city.buildings.faces.shape, city.crs.to_epsg(), city.terrain is None
((12, 3), 2056, True)
>>> city.buildings.vertices.min(axis=0).tolist(), city.buildings.vertices.max(axis=0).tolist()
([1000.0, 2000.0, 0.0], [1010.0, 2008.0, 6.0])
"""
from __future__ import annotations

import json
import os
import re
from collections import Counter
from dataclasses import dataclass, field
from itertools import chain
from typing import Callable, Optional

import numpy as np

from ..errors import UrbanvoxError
from ..polygons import triangulate_polygons
from ..progress import check_cancel
from .mesh import Triangles, clean_triangles

__all__ = ["CityModel", "read_cityjson", "is_cityjson", "BUILDING_TYPES", "TERRAIN_TYPES"]

#: City objects whose surfaces are the buildings.
BUILDING_TYPES = frozenset({"Building", "BuildingPart", "BuildingInstallation"})
#: City objects whose surfaces are the terrain.
TERRAIN_TYPES = frozenset({"TINRelief"})
#: Geometry types with surfaces, and how many levels of lists lie above their surfaces.
SURFACE_LEVELS = {"MultiSurface": 0, "CompositeSurface": 0, "Solid": 1, "MultiSolid": 2, "CompositeSolid": 2}


@dataclass
class CityModel:
    """The parts of a CityJSON file the method uses.

    Attributes
    ----------
    buildings : Triangles or None
        The buildings' surfaces, triangulated and cleaned, with each face's
        building (``owner``, ``owner_ids``: a ``BuildingPart``'s or an
        installation's is the building it is part of, through ``parents``);
        None in a file of terrain only.
    terrain : Triangles or None
        The ``TINRelief`` surfaces, when the file has any.
    crs : pyproj.CRS or None
        From ``metadata.referenceSystem``; None when the file names none.
    warnings : list of str
    """

    buildings: Optional[Triangles]
    terrain: Optional[Triangles]
    crs: object
    warnings: list = field(default_factory=list)


def is_cityjson(path: "str | os.PathLike[str]") -> bool:
    """Whether ``path`` names a CityJSON file (``.json``, ``.city.json``) or a CityJSON
    Sequence (``.jsonl``, ``.city.jsonl``).

    Example
    -------
    >>> is_cityjson("rotterdam.city.json"), is_cityjson("3dbag.city.jsonl"), is_cityjson("zurich.stl")
    (True, True, False)
    """
    return os.fspath(path).lower().endswith((".json", ".jsonl"))


def read_cityjson(path: "str | os.PathLike[str]", is_cancelled: Optional[Callable[[], bool]] = None,
                  lod: "str | None" = None) -> CityModel:
    """Read a CityJSON file's buildings, terrain and CRS (see the module doc).

    Parameters
    ----------
    path : str or path-like
        A CityJSON file (version 1.0 to 2.0) or a CityJSON Sequence (``.jsonl``).
    is_cancelled : callable, optional
        Zero-argument callable; True raises :class:`~core.errors.Cancelled`.
    lod : str, optional
        The level of detail to take ("1.2", "2"...) from the objects that
        have it; the others, and all objects by default, give their highest.

    Returns
    -------
    CityModel

    Raises
    ------
    UrbanvoxError
        Missing file, not CityJSON, neither building nor terrain surfaces,
        vertex indices out of range, or no triangle left after cleaning.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise UrbanvoxError(f"CityJSON file {path} does not exist; check the path.")
    header, documents = _documents(path)
    check_cancel(is_cancelled)
    if lod and not re.fullmatch(r"\d+(\.\d+)?", str(lod).strip()):
        raise UrbanvoxError(f"The LoD {lod!r} is not a level of detail: write it as CityJSON does, e.g. 1.2 or 2.")
    wanted = _lod({"lod": lod}) if lod else None
    with_wanted = 0
    warnings: list = []
    # The geometries chosen, each with its document's first vertex and number of vertices,
    # and its object's identifier.
    chosen: dict = {"building": [], "terrain": []}
    left_out: Counter = Counter()
    parent_of: dict = {}
    vertices = []
    first_vertex = 0
    for document in documents:  # one, or a sequence's features (a building each)
        vertices.append(_vertices(document, header, path))
        own = (first_vertex, len(vertices[-1]))
        for object_id, city_object in document["CityObjects"].items():  # objects, not faces
            geometries = (city_object.get("geometry") or []) if isinstance(city_object, dict) else None
            if not isinstance(geometries, list) or not all(isinstance(g, dict) for g in geometries):
                raise UrbanvoxError(f"{path}: the city object {object_id!r} is not an object with a list of "
                                    "geometries; the file is damaged.")
            kind = city_object.get("type", "")
            role = "building" if kind in BUILDING_TYPES else "terrain" if kind in TERRAIN_TYPES else None
            if role is None:
                left_out[kind] += len(geometries)
                continue
            with_surfaces = [g for g in geometries if g.get("type") in SURFACE_LEVELS and g.get("boundaries")]
            for geometry in geometries:
                if geometry.get("type") not in SURFACE_LEVELS:  # templates, points, lines
                    left_out[f"{kind} {geometry.get('type')}"] += 1
            parents = city_object.get("parents")
            if role == "building" and parents and isinstance(parents, list):
                parent_of[object_id] = str(parents[0])
            if with_surfaces:
                levels = [_lod(g) for g in with_surfaces]
                level = wanted if wanted in levels else max(levels)
                with_wanted += level == wanted
                chosen[role].extend((*own, g, object_id) for g, at in zip(with_surfaces, levels) if at == level)
        first_vertex += own[1]
    vertices = np.concatenate(vertices)
    if len(vertices) == 0:
        raise UrbanvoxError(f"{path}: no vertices; the file holds no geometry.")
    if not chosen["building"] and not chosen["terrain"]:
        raise UrbanvoxError(f"{path} has no building or terrain surfaces (Building, BuildingPart, "
                            "BuildingInstallation or TINRelief objects with MultiSurface, CompositeSurface or "
                            "Solid geometries).")
    if wanted is not None and with_wanted == 0:
        warnings.append(f"{os.path.basename(path)}: no object has LoD {lod}; each gives its highest.")
    if +left_out:
        listed = ", ".join(f"{n} {kind}" for kind, n in sorted((+left_out).items()))
        warnings.append(f"{os.path.basename(path)}: left out geometries that are not building or terrain "
                        f"surfaces: {listed}.")
    check_cancel(is_cancelled)
    buildings = terrain = None
    if chosen["building"]:
        # Each face's building: a part's or an installation's is the building it is part of.
        root = [_root(object_id, parent_of) for *_, object_id in chosen["building"]]
        ids, owner = np.unique(np.array(root, dtype=object), return_inverse=True)
        buildings = _triangles(vertices, chosen["building"], path, is_cancelled, owner, tuple(ids))
    if chosen["terrain"]:
        terrain = _triangles(vertices, chosen["terrain"], path, is_cancelled)
    crs = _reference_system(header.get("metadata") or {}, path, warnings)
    for part in (buildings, terrain):
        warnings += part.warnings if part is not None else []
    return CityModel(buildings=buildings, terrain=terrain, crs=crs, warnings=warnings)


def _documents(path: str) -> tuple[dict, list]:
    """The file's header (its CityJSON object) and the documents holding its city objects: the
    header itself, or in a CityJSON Sequence (``.jsonl``: a CityJSON line, then a
    CityJSONFeature per line, each with vertices of its own) the features."""
    sequence = path.lower().endswith(".jsonl")
    if os.path.getsize(path) == 0:
        raise UrbanvoxError(f"{path} is empty; give a CityJSON file with buildings.")
    try:
        with open(path, "rb") as file:
            if sequence:  # a line per building: a loop per object, not per face
                lines = [json.loads(line) for line in file if line.strip()]
            else:
                lines = [json.load(file)]
    except (ValueError, UnicodeDecodeError) as exc:
        raise UrbanvoxError(f"{path} is not a JSON file ({exc}); give a CityJSON file (.json, .city.json) "
                            "or a CityJSON Sequence (.jsonl).") from exc
    header = lines[0] if lines else None
    if not isinstance(header, dict) or header.get("type") != "CityJSON" or not isinstance(
            header.get("CityObjects"), dict):
        raise UrbanvoxError(f"{path} is JSON but not CityJSON (no \"type\": \"CityJSON\" with CityObjects"
                            f"{' on its first line' if sequence else ''}); GeoJSON is not read.")
    if not sequence:
        return header, [header]
    features = lines[1:]
    wrong = [n + 2 for n, f in enumerate(features)
             if not isinstance(f, dict) or f.get("type") != "CityJSONFeature" or not isinstance(
                 f.get("CityObjects"), dict)]
    if wrong:
        raise UrbanvoxError(f"{path}: line {wrong[0]} (not counting blank lines) is not a CityJSONFeature with "
                            f"CityObjects ({len(wrong)} such lines); the file is damaged.")
    # The header's own city objects, if it has any (a sequence's has none, normally).
    return header, ([header] if header["CityObjects"] else []) + features


def _vertices(document: dict, header: dict, path: str) -> np.ndarray:
    """A document's vertices in world coordinates (the header's ``transform`` applied)."""
    try:
        vertices = np.asarray(document.get("vertices") or np.empty((0, 3)), dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise UrbanvoxError(f"{path}: the vertices are not a list of [x, y, z] numbers ({exc}).") from exc
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise UrbanvoxError(f"{path}: vertices that are not [x, y, z]; the file is damaged.")
    transform = header.get("transform")
    if transform:
        try:
            scale = np.asarray(transform.get("scale", (1, 1, 1)), dtype=np.float64).reshape(3)
            translate = np.asarray(transform.get("translate", (0, 0, 0)), dtype=np.float64).reshape(3)
        except (AttributeError, TypeError, ValueError) as exc:
            raise UrbanvoxError(f"{path}: the transform is not {{\"scale\": [3 numbers], \"translate\": "
                                f"[3 numbers]}} ({exc}); the file is damaged.") from exc
        vertices = vertices * scale + translate
    return vertices


def _lod(geometry: dict) -> tuple:
    """A geometry's level of detail as a comparable tuple: "2.2" -> (2, 2), 1 -> (1,), "2.0" -> (2,)."""
    try:
        parts = [int(part) for part in str(geometry.get("lod", 0)).strip().split(".")]
        while len(parts) > 1 and parts[-1] == 0:
            parts.pop()
        return tuple(parts)
    except ValueError:
        return (0,)


def _root(object_id: str, parent_of: dict) -> str:
    """The building an object is part of: its parent's, up to an object without one."""
    seen = {object_id}
    while object_id in parent_of and parent_of[object_id] not in seen:
        object_id = parent_of[object_id]
        seen.add(object_id)
    return object_id


def _triangles(vertices: np.ndarray, geometries: list, path: str,
               is_cancelled: Optional[Callable[[], bool]], owner: Optional[np.ndarray] = None,
               owner_ids: tuple = ()) -> Triangles:
    """The polygons of ``geometries`` (each with its document's first vertex, number of
    vertices and object) as cleaned triangles of ``vertices``; ``owner``, the
    index of each geometry's building in ``owner_ids``, passed on to its triangles."""
    surfaces: list = []
    surface_counts = np.empty(len(geometries), dtype=np.int64)
    first_vertex, document_size = np.array([(first, size) for first, size, *_ in geometries], dtype=np.int64).T
    try:
        for n, (_, _, geometry, _) in enumerate(geometries):
            boundaries = geometry["boundaries"]
            for _ in range(SURFACE_LEVELS[geometry["type"]]):
                boundaries = list(chain.from_iterable(boundaries))
            surfaces.extend(boundaries)
            surface_counts[n] = len(boundaries)
        # The nesting flattened in C (chain, map): no Python loop per polygon or vertex.
        rings = list(chain.from_iterable(surfaces))
        ring_counts = np.fromiter(map(len, surfaces), dtype=np.int64, count=len(surfaces))
        ring_sizes = np.fromiter(map(len, rings), dtype=np.int64, count=len(rings))
        index = np.fromiter(chain.from_iterable(rings), dtype=np.int64, count=int(ring_sizes.sum()))
    except (TypeError, ValueError) as exc:
        raise UrbanvoxError(f"{path}: a surface's boundary is not nested as its geometry type says ({exc}).") from exc
    # Each document numbers its own vertices (a sequence's features): from its first in all.
    of_geometry = np.repeat(np.repeat(np.repeat(np.arange(len(geometries)), surface_counts), ring_counts), ring_sizes)
    outside = np.flatnonzero((index < 0) | (index >= document_size[of_geometry]))
    if len(outside):
        raise UrbanvoxError(f"{path}: a boundary refers to vertex {int(index[outside[0]])}, but its document has "
                            f"{int(document_size[of_geometry[outside[0]]])} vertices; the file is damaged.")
    index = index + first_vertex[of_geometry]
    check_cancel(is_cancelled)
    surface_owner = None if owner is None else np.repeat(owner, surface_counts)
    # A vertex given as null (NaN) or beyond a float: the surfaces that use it are dropped, as a mesh's faces.
    dropped = 0
    non_finite = ~np.isfinite(vertices).all(axis=1)
    if non_finite.any():
        ring_of_point = np.repeat(np.arange(len(ring_sizes)), ring_sizes)
        bad_ring = np.bincount(ring_of_point, weights=non_finite[index], minlength=len(ring_sizes)) > 0
        surface_of_ring = np.repeat(np.arange(len(ring_counts)), ring_counts)
        bad_surface = np.bincount(surface_of_ring, weights=bad_ring, minlength=len(ring_counts)) > 0
        kept_ring = ~bad_surface[surface_of_ring]
        index = index[kept_ring[ring_of_point]]
        ring_sizes, ring_counts = ring_sizes[kept_ring], ring_counts[~bad_surface]
        surface_owner = None if surface_owner is None else surface_owner[~bad_surface]
        dropped = int(bad_surface.sum())
    all_vertices, faces, polygon = triangulate_polygons(vertices, index, ring_sizes, ring_counts)
    if len(faces) == 0:
        raise UrbanvoxError(f"{path}: no surface has an area (every polygon is degenerate"
                            f"{' or has a vertex that is not a number' if dropped else ''}).")
    face_owner = None if surface_owner is None else surface_owner.take(polygon)
    triangles = clean_triangles(all_vertices, faces, path, is_cancelled, face_owner, owner_ids)
    if dropped:
        triangles.warnings.append(f"{os.path.basename(path)}: dropped {dropped} surfaces with a vertex that is not a "
                                  "number (null, NaN or infinite).")
    return triangles


def _reference_system(metadata: dict, path: str, warnings: list):
    """``metadata.referenceSystem`` as a pyproj CRS, None when absent or not understood (with a warning)."""
    import pyproj

    text = metadata.get("referenceSystem") or metadata.get("crs")
    if not text:
        return None
    try:
        return pyproj.CRS.from_user_input(str(text))
    except pyproj.exceptions.CRSError:
        warnings.append(f"{os.path.basename(path)}: referenceSystem {text!r} is not a CRS PROJ knows; "
                        "it is ignored (set the CRS parameter).")
        return None
