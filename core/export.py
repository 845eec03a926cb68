"""Mesh files of a reconstruction: OBJ, PLY, STL, VTU and gmsh MSH.

Every file is written from the triangulated :class:`~core.surface.SurfaceModel`
(each quad split once, along its best diagonal), so the surfaces of
neighbouring regions share their nodes and triangles in every format:

===========  ==============================================================
``.obj``     one group per region (``block_1``, ..., ``ground``, ``air``),
             each the closed, outward surface of that region
``.stl``     ASCII, one named ``solid`` per region (OpenFOAM's
             ``snappyHexMesh`` and gmsh read the names)
``.ply``     binary, the closed surface of every region with a ``region``
             face property (block id, -1 ground, -2 air)
``.vtu``     ParaView: every interface face once, with ``region_a`` /
             ``region_b`` (the two regions, normal from a into b) and
             ``block_id`` cell data (meshio)
``.msh``     gmsh 4.1: a physical surface per interface (``block_3|air``,
             ``ground|air``, ...) and a physical volume per region
             (``block_3``, ``ground``, ``air``); entities are the connected
             patches of the interfaces and the closed shells of the regions
             they bound, so a volume mesher or solver can tag every boundary
===========  ==============================================================

Coordinates are world coordinates (the CRS of the input). Files are
written to a temporary name and renamed, so a failed or cancelled write
never leaves a partial file.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .errors import UrbanvoxError
from .surface import AIR_REGION, GROUND_REGION, OUTSIDE_REGION, REGION_NAMES, SurfaceModel

MESH_FORMATS = (".obj", ".stl", ".ply", ".vtu", ".msh")


def region_name(region: int) -> str:
    """``block_7``, ``ground``, ``air`` or ``outside``."""
    return f"block_{region}" if region > 0 else REGION_NAMES[region]


def write_mesh(path: str | Path, model: SurfaceModel, offset: np.ndarray) -> Path:
    """Write the model's regions to ``path``; the suffix picks the format.

    Parameters
    ----------
    path : str or Path
    model : SurfaceModel
        Final (smoothed, projected) model, local coordinates.
    offset : ndarray (3,)
        Added to the node coordinates (local -> world).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    writers = {".obj": _write_obj, ".stl": _write_stl, ".ply": _write_ply,
               ".vtu": _write_vtu, ".msh": _write_msh}
    if suffix not in writers:
        raise UrbanvoxError(f"Unknown mesh format '{suffix}': use one of {', '.join(MESH_FORMATS)}.")
    tri = model.triangulated()
    world = tri.nodes + np.asarray(offset, dtype=np.float64)
    temporary = path.with_name(f".{path.name}.part")
    try:
        writers[suffix](temporary, tri, world)
        os.replace(temporary, path)
    finally:
        if temporary.exists():
            temporary.unlink()
    return path


def _regions(model: SurfaceModel) -> list[int]:
    """Blocks in id order, then the ground and the air."""
    ids = [int(r) for r in model.region_ids() if r > 0]
    return ids + [r for r in (GROUND_REGION, AIR_REGION) if r in set(model.regions.ravel().tolist())]


def _grouped_surfaces(model: SurfaceModel, regions: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """The closed surfaces of ``regions`` one after the other, and where each starts.

    Returns
    -------
    faces : ndarray of int, shape (F, 3)
        As :meth:`SurfaceModel.closed_surfaces`.
    bounds : ndarray of int, shape (len(regions) + 1,)
        Region ``regions[i]`` owns ``faces[bounds[i]:bounds[i + 1]]``.
    """
    faces, labels = model.closed_surfaces(regions)
    counts = np.zeros(len(regions), dtype=np.int64)
    if len(faces):
        # Labels run in the order of ``regions``: count each region's rows.
        change = np.flatnonzero(np.diff(labels)) + 1
        starts = np.concatenate([[0], change])
        counts_found = np.diff(np.concatenate([starts, [len(labels)]]))
        position = {r: i for i, r in enumerate(regions)}
        counts[[position[int(r)] for r in labels[starts]]] = counts_found
    return faces, np.concatenate([[0], np.cumsum(counts)])


def _write_obj(path: Path, model: SurfaceModel, world: np.ndarray) -> None:
    regions = _regions(model)
    faces, bounds = _grouped_surfaces(model, regions)
    with open(path, "w", encoding="ascii") as out:
        out.write("# urbanvox: one closed, outward surface per region\n")
        np.savetxt(out, world, fmt="v %.4f %.4f %.4f")
        for i, region in enumerate(regions):
            out.write(f"g {region_name(region)}\n")
            np.savetxt(out, faces[bounds[i]:bounds[i + 1]] + 1, fmt="f %d %d %d")


def _write_stl(path: Path, model: SurfaceModel, world: np.ndarray) -> None:
    regions = _regions(model)
    faces, bounds = _grouped_surfaces(model, regions)
    with open(path, "w", encoding="ascii") as out:
        for i, region in enumerate(regions):
            tri = world[faces[bounds[i]:bounds[i + 1]]]
            normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
            rows = np.concatenate([normal[:, None, :], tri], axis=1).reshape(len(tri), 12)
            name = region_name(region)
            out.write(f"solid {name}\n")
            np.savetxt(out, rows, fmt=("facet normal %.6e %.6e %.6e\n outer loop\n"
                                       "  vertex %.4f %.4f %.4f\n  vertex %.4f %.4f %.4f\n"
                                       "  vertex %.4f %.4f %.4f\n endloop\nendfacet"))
            out.write(f"endsolid {name}\n")


def _write_ply(path: Path, model: SurfaceModel, world: np.ndarray) -> None:
    # Every region's closed surface in one pass (a scan of all faces per
    # region would cost regions x faces).
    faces, labels = model.closed_surfaces(_regions(model))
    header = ("ply\nformat binary_little_endian 1.0\ncomment urbanvox: closed surface per region\n"
              f"element vertex {len(world)}\nproperty double x\nproperty double y\nproperty double z\n"
              f"element face {len(faces)}\nproperty list uchar int vertex_indices\n"
              "property int region\nend_header\n")
    face_dtype = np.dtype([("n", "u1"), ("v", "<i4", (3,)), ("region", "<i4")])
    records = np.empty(len(faces), dtype=face_dtype)
    records["n"] = 3
    records["v"] = faces
    records["region"] = labels
    with open(path, "wb") as out:
        out.write(header.encode("ascii"))
        out.write(world.astype("<f8").tobytes())
        out.write(records.tobytes())


def _write_vtu(path: Path, model: SurfaceModel, world: np.ndarray) -> None:
    try:
        import meshio
    except ImportError as error:  # pragma: no cover - dependency message
        raise UrbanvoxError("Writing .vtu needs the meshio package: "
                            "python3 -m pip install meshio") from error
    a, b = model.regions[:, 0], model.regions[:, 1]
    block = np.where(a > 0, a, np.where(b > 0, b, -1))
    mesh = meshio.Mesh(world, [("triangle", model.quads.astype(np.int64))],
                       cell_data={"region_a": [a.astype(np.int32)], "region_b": [b.astype(np.int32)],
                                  "block_id": [block.astype(np.int32)]})
    meshio.write(str(path), mesh, file_format="vtu")


def _write_msh(path: Path, model: SurfaceModel, world: np.ndarray) -> None:
    """gmsh 4.1 ASCII with the entity topology: interfaces bound the regions.

    A gmsh entity must be connected, so every interface is split into its
    connected patches and every region into its closed shells (one per
    cluster of scattered data, see :mod:`core.clusters`); the physical groups
    gather them back by name.
    """
    pairs = np.sort(model.regions, axis=1)  # faces stored from the lower region id into the higher
    faces = model.quads.copy()
    flip = model.regions[:, 0] > model.regions[:, 1]
    faces[flip] = faces[flip, ::-1]
    interfaces, which = np.unique(pairs, axis=0, return_inverse=True)
    which = which.ravel()
    # Surface entities: connected patches of each interface.
    patch = np.empty(len(faces), dtype=np.int64)
    patch_interface = []
    for i in range(len(interfaces)):
        sel = np.flatnonzero(which == i)
        labels = _face_components(faces[sel], len(world))
        patch[sel] = len(patch_interface) + labels
        patch_interface.extend([i] * (int(labels.max()) + 1))
    patch_interface = np.asarray(patch_interface)
    # Volume entities: closed shells of each region, made of whole patches.
    regions = _regions(model)
    shells = []  # (region, [signed patch tags])
    for r in regions:
        touching = np.flatnonzero((interfaces[patch_interface] == r).any(axis=1))
        sel = np.flatnonzero(np.isin(patch, touching))
        labels = _face_components(faces[sel], len(world))
        for shell in range(int(labels.max()) + 1):
            own = np.unique(patch[sel[labels == shell]])
            sign = np.where(interfaces[patch_interface[own], 0] == r, 1, -1)  # normal out of r: +
            shells.append((r, (sign * (own + 1)).tolist()))
    physical_region = {r: i + 1 for i, r in enumerate(regions)}
    names = []
    for s, (ra, rb) in enumerate(interfaces, start=1):
        label = region_name(int(rb)) if ra == OUTSIDE_REGION else f"{region_name(int(ra))}|{region_name(int(rb))}"
        names.append(f'2 {s} "{label}"')
    for r, v in physical_region.items():
        names.append(f'3 {v} "{region_name(r)}"')
    lines = ["$MeshFormat", "4.1 0 8", "$EndMeshFormat",
             "$PhysicalNames", str(len(names)), *names, "$EndPhysicalNames",
             "$Entities", f"0 0 {len(patch_interface)} {len(shells)}"]
    for p, i in enumerate(patch_interface, start=1):
        box = world[faces[patch == p - 1].ravel()]
        lines.append(f"{p} {_box(box)} 1 {i + 1} 0")
    for v, (r, bounding) in enumerate(shells, start=1):
        box = world[faces[np.isin(patch, np.abs(bounding) - 1)].ravel()]
        lines.append(f"{v} {_box(box)} 1 {physical_region[r]} {len(bounding)} " + " ".join(map(str, bounding)))
    lines.append("$EndEntities")
    n_nodes = len(world)
    # All nodes in one block on the first surface entity: node tags are
    # global in gmsh, and each shared node is stored once.
    lines += ["$Nodes", f"1 {n_nodes} 1 {n_nodes}", f"2 1 0 {n_nodes}"]
    order = np.argsort(patch, kind="stable")
    bounds = np.searchsorted(patch[order], np.arange(len(patch_interface) + 1))
    with open(path, "w", encoding="ascii") as out:
        out.write("\n".join(lines) + "\n")
        np.savetxt(out, np.arange(1, n_nodes + 1), fmt="%d")
        np.savetxt(out, world, fmt="%.4f %.4f %.4f")
        out.write("$EndNodes\n$Elements\n")
        out.write(f"{len(patch_interface)} {len(faces)} 1 {len(faces)}\n")
        for p in range(len(patch_interface)):
            members = order[bounds[p]:bounds[p + 1]]
            out.write(f"2 {p + 1} 2 {len(members)}\n")
            np.savetxt(out, np.column_stack([members + 1, faces[members] + 1]), fmt="%d")
        out.write("$EndElements\n")


def _box(points: np.ndarray) -> str:
    lo, hi = points.min(axis=0), points.max(axis=0)
    return f"{lo[0]:.4f} {lo[1]:.4f} {lo[2]:.4f} {hi[0]:.4f} {hi[1]:.4f} {hi[2]:.4f}"


def _face_components(faces: np.ndarray, n_nodes: int) -> np.ndarray:
    """Component of every face, faces being connected through shared nodes."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    rows = np.repeat(np.arange(len(faces)), faces.shape[1])
    # Faces and nodes in one bipartite graph: faces sharing a node are connected.
    graph = coo_matrix((np.ones(len(rows), np.int8), (rows, len(faces) + faces.ravel())),
                       shape=(len(faces) + n_nodes, len(faces) + n_nodes))
    _, labels = connected_components(graph, directed=False)
    _, compact = np.unique(labels[:len(faces)], return_inverse=True)
    return compact.ravel()
