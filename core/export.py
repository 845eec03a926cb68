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
``.msh``     gmsh 4.1: one surface entity per interface with a physical
             surface (``block_3|air``, ``ground|air``, ...), one volume
             entity per region bounded by its interfaces, with a physical
             volume (``block_3``, ``ground``, ``air``), so a volume mesher
             or solver can tag every boundary
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


def _write_obj(path: Path, model: SurfaceModel, world: np.ndarray) -> None:
    with open(path, "w", encoding="ascii") as out:
        out.write("# urbanvox: one closed, outward surface per region\n")
        np.savetxt(out, world, fmt="v %.4f %.4f %.4f")
        for region in _regions(model):
            out.write(f"g {region_name(region)}\n")
            np.savetxt(out, model.closed_surface(region) + 1, fmt="f %d %d %d")


def _write_stl(path: Path, model: SurfaceModel, world: np.ndarray) -> None:
    with open(path, "w", encoding="ascii") as out:
        for region in _regions(model):
            tri = world[model.closed_surface(region)]
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
    regions = _regions(model)
    faces = [model.closed_surface(r) for r in regions]
    labels = np.concatenate([np.full(len(f), r, dtype=np.int32) for f, r in zip(faces, regions)])
    faces = np.concatenate(faces)
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
    """gmsh 4.1 ASCII with the entity topology: interfaces bound the regions."""
    pairs = np.sort(model.regions, axis=1)
    # Faces against the outside of the domain bound only the region inside.
    interfaces, which = np.unique(pairs, axis=0, return_inverse=True)
    which = which.ravel()
    regions = _regions(model)
    volume_tag = {r: i + 1 for i, r in enumerate(regions)}
    lines = ["$MeshFormat", "4.1 0 8", "$EndMeshFormat"]
    # Physical groups: surfaces 1..S (one per interface), volumes 1..V.
    names = []
    for s, (ra, rb) in enumerate(interfaces, start=1):
        label = region_name(int(rb)) if ra == OUTSIDE_REGION else f"{region_name(int(ra))}|{region_name(int(rb))}"
        names.append(f'2 {s} "{label}"')
    for r, v in volume_tag.items():
        names.append(f'3 {v} "{region_name(r)}"')
    lines += ["$PhysicalNames", str(len(names)), *names, "$EndPhysicalNames"]
    # Entities: no points or curves; surfaces with their bounding box and
    # physical tag; volumes bounded by signed surface tags (sign: the face
    # normal points out of the volume for +, into it for -). Each interface's
    # faces are stored with the normal from its lower region id into the higher.
    entities = ["$Entities", f"0 0 {len(interfaces)} {len(volume_tag)}"]
    for s, (ra, rb) in enumerate(interfaces, start=1):
        sel = which == s - 1
        box = world[model.quads[sel].ravel()]
        lo, hi = box.min(axis=0), box.max(axis=0)
        entities.append(f"{s} {lo[0]:.4f} {lo[1]:.4f} {lo[2]:.4f} {hi[0]:.4f} {hi[1]:.4f} {hi[2]:.4f} 1 {s} 0")
    for r, v in volume_tag.items():
        bounding = []
        for s, (ra, rb) in enumerate(interfaces, start=1):
            if ra == r:
                bounding.append(s)      # normal from ra (this region) outwards
            elif rb == r:
                bounding.append(-s)
        lo, hi = world.min(axis=0), world.max(axis=0)
        entities.append(f"{v} {lo[0]:.4f} {lo[1]:.4f} {lo[2]:.4f} {hi[0]:.4f} {hi[1]:.4f} {hi[2]:.4f} "
                        f"1 {v} {len(bounding)} " + " ".join(map(str, bounding)))
    entities.append("$EndEntities")
    lines += entities
    # Orient every face from the lower region id into the higher one.
    faces = model.quads.copy()
    flip = model.regions[:, 0] > model.regions[:, 1]
    faces[flip] = faces[flip, ::-1]
    n_nodes = len(world)
    # All nodes in one block on the first surface entity: node tags are
    # global in gmsh, and each shared node is stored once.
    node_lines = ["$Nodes", f"1 {n_nodes} 1 {n_nodes}", f"2 1 0 {n_nodes}"]
    element_blocks = []
    start = 1
    for s in range(1, len(interfaces) + 1):
        sel = faces[which == s - 1] + 1
        tags = np.arange(start, start + len(sel))
        element_blocks.append((s, np.column_stack([tags, sel])))
        start += len(sel)
    with open(path, "w", encoding="ascii") as out:
        out.write("\n".join(lines + node_lines) + "\n")
        np.savetxt(out, np.arange(1, n_nodes + 1), fmt="%d")
        np.savetxt(out, world, fmt="%.4f %.4f %.4f")
        out.write("$EndNodes\n$Elements\n")
        out.write(f"{len(element_blocks)} {start - 1} 1 {start - 1}\n")
        for s, rows in element_blocks:
            out.write(f"2 {s} 2 {len(rows)}\n")
            np.savetxt(out, rows, fmt="%d")
        out.write("$EndElements\n")
