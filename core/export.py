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
             ``block_id`` cell data (:mod:`core.vtu`)
``.msh``     gmsh 4.1, text or binary: a physical surface per interface
             (``block_3|air``, ``ground|air``, ...) and a physical volume
             per region (``block_3``, ``ground``, ``air``); entities are the
             connected patches of the interfaces and the closed shells of
             the regions they bound, so a volume mesher or solver can tag
             every boundary
===========  ==============================================================

Coordinates are world coordinates (the CRS of the input). Files are
written to a temporary name and renamed, so a failed or cancelled write
never leaves a partial file.
"""
from __future__ import annotations

import functools
import os
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np

from . import jit
from .errors import UrbanvoxError
from .heap import reusing_freed_memory
from .parallel import map_ahead
from .progress import CancelCheck, cancel_checked, check_cancel
from .row_text import encoded_block, write_rows
from .surface import AIR_REGION, GROUND_REGION, OUTSIDE_REGION, REGION_NAMES, SurfaceModel, rank_in, unique_pairs
from .vtu import write_vtu

MESH_FORMATS = (".obj", ".stl", ".ply", ".vtu", ".msh")
#: Rows written at a time.
_ROWS = 65536


def check_output_path(path: str | Path, suffixes: tuple[str, ...] | None = MESH_FORMATS) -> Path:
    """``path`` if a file can be written there (by default a mesh, its suffix
    one of :data:`MESH_FORMATS`; any with ``suffixes`` None), else an
    :class:`UrbanvoxError` that says why: checked before a run, not after its
    minutes of work.

    Examples
    --------
    >>> check_output_path("/tmp/city.msh").name
    'city.msh'
    >>> try:
    ...     check_output_path("/tmp/city.txt")
    ... except UrbanvoxError as error:
    ...     print(error)
    Unknown mesh format '.txt' (/tmp/city.txt): use one of .obj, .stl, .ply, .vtu, .msh.
    """
    path = Path(path)
    if suffixes is not None and path.suffix.lower() not in suffixes:
        raise UrbanvoxError(f"Unknown mesh format '{path.suffix}' ({path}): use one of {', '.join(suffixes)}.")
    folder = path.parent  # "." for a bare file name
    if path.is_dir():
        raise UrbanvoxError(f"{path} is a folder: give a file name in it.")
    if not folder.is_dir():
        raise UrbanvoxError(f"The folder {folder} of {path.name} does not exist: create it first.")
    if not os.access(folder, os.W_OK | os.X_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise UrbanvoxError(f"{path} cannot be written here (no permission).")
    return path


def region_name(region: int) -> str:
    """``block_7``, ``ground``, ``air`` or ``outside``."""
    return f"block_{region}" if region > 0 else REGION_NAMES[region]


@reusing_freed_memory()
def write_mesh(path: str | Path, model: SurfaceModel, offset: np.ndarray, binary: bool = False,
               triangles: SurfaceModel | None = None, is_cancelled: CancelCheck | None = None) -> Path:
    """Write the model's regions to ``path``; the suffix picks the format.

    Parameters
    ----------
    path : str or Path
    model : SurfaceModel
        Final (smoothed, projected) model, local coordinates.
    offset : ndarray (3,)
        Added to the node coordinates (local -> world).
    binary : bool
        Write a ``.msh`` in gmsh's binary encoding: the same content, faster
        to write on a city (the 1 km city's: 1.6-2.1 s, 2.3-3.6 s as text;
        the entity search is the same), and exact coordinates. The other
        formats have one encoding each (PLY binary, VTU zlib-compressed binary,
        OBJ and STL text: a binary STL cannot name its solids) and ignore it.
    triangles : SurfaceModel, optional
        ``model.triangulated()``, when the caller has it.
    is_cancelled : callable, optional
        Asked before every write into the file (a block of rows at most):
        :class:`core.errors.Cancelled` then, and nothing is left at ``path``
        (the file is written into a temporary beside it, renamed when whole).
    """
    path = check_output_path(path)
    suffix = path.suffix.lower()
    writers = {".obj": _write_obj, ".stl": _write_stl, ".ply": _write_ply, ".vtu": _write_vtu,
               ".msh": lambda path, tri, world, cancel: _write_msh(path, model, tri, world, binary, cancel)}
    check_cancel(is_cancelled)
    tri = triangles if triangles is not None else model.triangulated()
    world = tri.nodes + np.asarray(offset, dtype=np.float64)
    temporary = path.with_name(f".{path.name}.part")
    try:
        writers[suffix](temporary, tri, world, is_cancelled)
        os.replace(temporary, path)
    finally:
        if temporary.exists():
            temporary.unlink()
    return path


@contextmanager
def _opened(path: Path, mode: str, is_cancelled: CancelCheck | None) -> Iterator:
    """``open(path, mode)`` (ASCII text, or bytes), each write checking ``is_cancelled``
    first: the writers write a block of rows at a time, so a cancel waits for
    one block, not for the file."""
    with open(path, mode, **({} if "b" in mode else {"encoding": "ascii"})) as out:
        yield cancel_checked(out, is_cancelled)


def _regions(model: SurfaceModel) -> list[int]:
    """Blocks in id order, then the ground and the air."""
    present = model.region_ids()
    return present[present > 0].tolist() + [r for r in (GROUND_REGION, AIR_REGION) if r in present]


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


def _write_obj(path: Path, model: SurfaceModel, world: np.ndarray, is_cancelled: CancelCheck | None = None) -> None:
    regions = _regions(model)
    faces, bounds = _grouped_surfaces(model, regions)
    with _opened(path, "wb", is_cancelled) as out:  # ASCII text, written as bytes (core.row_text)
        out.write(b"# urbanvox: one closed, outward surface per region\n")
        write_rows(out, "v %.4f %.4f %.4f", world)
        for i, region in enumerate(regions):
            out.write(f"g {region_name(region)}\n".encode("ascii"))
            write_rows(out, "f %d %d %d", faces[bounds[i]:bounds[i + 1]] + 1)


#: One STL facet: its unit normal and three corners (the text of :mod:`core.row_text`).
_FACET = ("facet normal %.6f %.6f %.6f\n outer loop\n  vertex %.4f %.4f %.4f\n  vertex %.4f %.4f %.4f\n"
          "  vertex %.4f %.4f %.4f\n endloop\nendfacet")


def _write_stl(path: Path, model: SurfaceModel, world: np.ndarray, is_cancelled: CancelCheck | None = None) -> None:
    regions = _regions(model)
    faces, bounds = _grouped_surfaces(model, regions)

    def facets(rows: slice) -> bytes:
        # A block's normals and corners, then their text, on a thread (core.parallel):
        # the % operator's text of every facet took 43 s for the 1 km city's 3.2 GB.
        corner = faces[rows]
        tri = world.take(corner, axis=0)  # faster than world[corner] (core.vectors)
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
        return encoded_block(_FACET, np.concatenate([normal, tri.reshape(-1, 9)], axis=1), len(faces))

    with _opened(path, "wb", is_cancelled) as out:  # ASCII text, written as bytes (core.row_text)
        for i, region in enumerate(regions):
            name = region_name(region)
            out.write(f"solid {name}\n".encode("ascii"))
            blocks = [slice(start, min(start + _ROWS, bounds[i + 1]))
                      for start in range(bounds[i], bounds[i + 1], _ROWS)]
            for text in map_ahead(facets, blocks):
                out.write(text)
            out.write(f"endsolid {name}\n".encode("ascii"))


def _write_ply(path: Path, model: SurfaceModel, world: np.ndarray, is_cancelled: CancelCheck | None = None) -> None:
    # Every region's closed surface in one pass (a scan of all faces per
    # region would cost regions x faces).
    faces, labels = model.closed_surfaces(_regions(model))
    header = ("ply\nformat binary_little_endian 1.0\ncomment urbanvox: closed surface per region\n"
              f"element vertex {len(world)}\nproperty double x\nproperty double y\nproperty double z\n"
              f"element face {len(faces)}\nproperty list uchar int vertex_indices\n"
              "property int region\nend_header\n")
    face_dtype = np.dtype([("n", "u1"), ("v", "<i4", (3,)), ("region", "<i4")])
    with _opened(path, "wb", is_cancelled) as out:
        out.write(header.encode("ascii"))
        out.write(np.ascontiguousarray(world, dtype="<f8").data)  # no copy of the float64 nodes
        # The face records _ROWS at a time: a table of them all, then its
        # bytes, took 660 MB on the 1 km city, first written pages each time.
        records = np.empty(min(_ROWS, len(faces)), dtype=face_dtype)
        records["n"] = 3
        for start in range(0, len(faces), _ROWS):
            block = records[:min(_ROWS, len(faces) - start)]
            block["v"] = faces[start:start + len(block)]
            block["region"] = labels[start:start + len(block)]
            out.write(block.tobytes())


def _write_vtu(path: Path, model: SurfaceModel, world: np.ndarray, is_cancelled: CancelCheck | None = None) -> None:
    """Every interface triangle once, its two regions and block as cell data (:mod:`core.vtu`)."""
    a, b = model.regions[:, 0], model.regions[:, 1]
    block = np.where(a > 0, a, np.where(b > 0, b, -1))
    cell_data = {"region_a": a.astype(np.int32), "region_b": b.astype(np.int32), "block_id": block.astype(np.int32)}
    with _opened(path, "wb", is_cancelled) as out:
        write_vtu(out, world, model.quads, cell_data, is_cancelled)


@dataclass
class _MshTopology:
    """What a gmsh file says beyond nodes and faces: its entities and groups.

    Surface entity ``p + 1`` is patch ``p`` (a connected piece of one
    interface), volume entity ``v + 1`` is shell ``v`` (a closed piece of one
    region's boundary).
    """

    faces: np.ndarray            #: (F, 3) node indices, each face oriented from its lower region id
    names: list[str]             #: ``$PhysicalNames`` lines: ``2 s "block_3|air"``, ``3 v "block_3"``
    patch_physical: np.ndarray   #: (S,) physical surface (interface) tag of every patch
    patch_box: np.ndarray        #: (S, 6) lower and upper corner of every patch
    shell_physical: np.ndarray   #: (V,) physical volume (region) tag of every shell
    shell_box: np.ndarray        #: (V, 6)
    bounding: list[np.ndarray]   #: signed surface tags bounding every shell (+: normal out of it)
    face_order: np.ndarray       #: (F,) faces by patch
    patch_start: np.ndarray      #: (S + 1,) patch ``p`` has ``face_order[patch_start[p]:patch_start[p + 1]]``


def _msh_topology(model: SurfaceModel, world: np.ndarray, triangles: SurfaceModel | None = None) -> _MshTopology:
    """The gmsh entities: interfaces bound the regions.

    A gmsh entity must be connected, so every interface is split into its
    connected patches and every region into its closed shells (one per
    cluster of scattered data, see :mod:`core.clusters`); the physical groups
    gather them back by name. Patches are numbered by interface, then by
    their first face; shells by region, then by their first face.

    The entities are found on ``model``'s faces. The file's faces are
    ``triangles`` when given: ``model.triangulated()``, whose triangles
    ``2 f`` and ``2 f + 1`` split face ``f``. The two triangles of a quad
    share a side and hold its four corners, so the patches, shells, their
    numbering and boxes are those of the triangles, found on half the faces
    and two thirds of the links (the 1 km city: at most 2.0 GB of tables
    on the triangles, 1.45 GB on the quads).
    """
    # Faces go from the lower region id. Two columns' minimum and maximum,
    # not a sort of every row (0.13-0.2 s on the 1 km city's 4.9 M quads).
    behind, front = model.regions[:, 0], model.regions[:, 1]
    interfaces, which = unique_pairs(np.column_stack([np.minimum(behind, front), np.maximum(behind, front)]))
    regions = _regions(model)
    ids = np.asarray(regions, dtype=np.int64)
    side_rank = rank_in(interfaces, ids)
    found = jit.run("export_kernel", "msh_entities", model.quads, which, side_rank, world, size=len(model.quads))
    first_face, order, bounds, items, shell, patch_lower, patch_upper = \
        found if found is not None else _msh_entities(model.quads, which, side_rank, world)
    n_patches = len(first_face)
    patch_interface = which[first_face]
    item_patch = items % n_patches
    item_rank = side_rank[patch_interface[item_patch], items // n_patches]
    shell_rank = item_rank[np.unique(shell, return_index=True)[1]]
    shell_region = ids[shell_rank]
    # The patches of each shell, ascending, and whether the shell's region is
    # their interface's first (normal out of it: +) or second region.
    by_shell = np.lexsort((item_patch, shell))
    shell_of, patch_of = shell[by_shell], item_patch[by_shell]
    sign = np.where(interfaces[patch_interface[patch_of], 0] == shell_region[shell_of], 1, -1)
    bounding = np.split(sign * (patch_of + 1), np.flatnonzero(np.diff(shell_of)) + 1)
    # Each shell's box, of its patches'.
    shell_start = np.searchsorted(shell_of, np.arange(len(bounding)))
    shell_lower = np.minimum.reduceat(patch_lower[patch_of], shell_start)
    shell_upper = np.maximum.reduceat(patch_upper[patch_of], shell_start)

    # Physical surfaces are the interfaces (tag = rank + 1), physical volumes the regions.
    names = []
    for s, (ra, rb) in enumerate(interfaces, start=1):
        label = region_name(int(rb)) if ra == OUTSIDE_REGION else f"{region_name(int(ra))}|{region_name(int(rb))}"
        names.append(f'2 {s} "{label}"')
    names += [f'3 {v} "{region_name(r)}"' for v, r in enumerate(regions, start=1)]
    # The file's faces, each oriented from its lower region id into the higher.
    faces, flip = model.quads, model.regions[:, 0] > model.regions[:, 1]
    if triangles is not None:
        faces, flip = triangles.quads, np.repeat(flip, 2)
        order = (2 * order[:, None] + np.arange(2)).ravel()
        bounds = 2 * bounds
    # A copy, half as large; then the reversed rows' corners, a column at a
    # time (a boolean gather and scatter of the rows took 0.3-0.5 s on the
    # 1 km city's 9.7 M triangles, this 0.1-0.13 s).
    source, faces = faces, faces.astype(np.int32 if len(world) < 2**31 else np.int64)
    reversed_rows = np.flatnonzero(flip)
    k = faces.shape[1]
    for c in range(k):
        if c != k - 1 - c:
            faces[reversed_rows, c] = source[reversed_rows, k - 1 - c]
    return _MshTopology(faces=faces, names=names, patch_physical=patch_interface + 1,
                        patch_box=np.hstack([patch_lower, patch_upper]), shell_physical=shell_rank + 1,
                        shell_box=np.hstack([shell_lower, shell_upper]), bounding=bounding,
                        face_order=order, patch_start=bounds)


def _msh_entities(faces: np.ndarray, which: np.ndarray, side_rank: np.ndarray,
                  world: np.ndarray) -> tuple[np.ndarray, ...]:
    """The entities of :func:`_msh_topology`: patches of the interfaces and shells of the regions.

    Parameters
    ----------
    faces : ndarray of int (F, k)
    which : ndarray of int (F,)
        The interface of every face.
    side_rank : ndarray of int (I, 2)
        The rank of each interface's two regions among the regions written, -1 if not written.
    world : ndarray (N, 3)

    Returns
    -------
    first_face : ndarray of int (P,)
        Every patch's first face; patches are numbered by interface, then by first face.
    order, bounds : ndarray of int (F,), (P + 1,)
        The faces by patch: patch ``p`` has ``order[bounds[p]:bounds[p + 1]]``.
    items : ndarray of int (T,)
        The patches' sides that bound a region written, by region and then
        first face: side ``s`` of patch ``p`` is ``s P + p``.
    shell : ndarray of int32 (T,)
        The shell of every item, numbered by its first item.
    lower, upper : ndarray (P, 3)
        Every patch's box, signed zeros made positive.
    """
    n_nodes = len(world)
    # Surface entities: connected patches of every interface, all at once:
    # faces linked through an (interface, node) they share, numbered in the
    # order of the faces sorted by interface.
    face_order = np.argsort(which, kind="stable")
    k = faces.shape[1]
    index = np.int32 if max(len(faces), n_nodes, len(side_rank)) < 2**31 else np.int64  # halves the tables
    patch_sorted, pair, pair_patch = _linked_parts(
        np.repeat(np.arange(len(faces), dtype=index), k), np.repeat(which[face_order].astype(index), k),
        faces.take(face_order, axis=0).astype(index).ravel(), len(faces), n_nodes)
    patch = np.empty(len(faces), dtype=np.int64)
    patch[face_order] = patch_sorted
    first_face = face_order[np.unique(patch_sorted, return_index=True)[1]]
    n_patches = len(first_face)
    # Volume entities: closed shells of each region, made of whole patches. A
    # patch bounds the two regions of its interface: one item (region, patch)
    # per side, linked to the others of the region through the nodes their
    # faces share (the patches' (interface, node) pairs), numbered by region
    # and then first face.
    item_rank = side_rank[which[first_face]].T.ravel()             # side 0 of every patch, then side 1
    item_patch = np.tile(np.arange(n_patches), 2)
    real = np.flatnonzero(item_rank >= 0)
    items = real[np.lexsort((first_face[item_patch[real]], item_rank[real]))]
    # The links (two per pair) in 32 bits where their values fit (items up
    # to 2 x patches): a table of them per field, 2 x 5 M on the 1 km city.
    link = np.int32 if max(2 * n_patches, n_nodes, len(side_rank)) < 2**31 else np.int64
    item_of = np.full(2 * n_patches, -1, dtype=link)
    item_of[items] = np.arange(len(items))
    pair_interface, pair_node = (pair // n_nodes).astype(link), (pair % n_nodes).astype(link)
    link_side = np.repeat(np.array([0, 1], dtype=np.int8), len(pair))
    link_rank = side_rank.astype(link)[np.tile(pair_interface, 2), link_side]
    link_item = item_of[np.repeat(np.array([0, n_patches], dtype=link), len(pair))
                        + np.tile(pair_patch.astype(link), 2)]
    del link_side
    on_region = link_rank >= 0
    shell, _, _ = _linked_parts(link_item[on_region], link_rank[on_region],
                                np.tile(pair_node, 2)[on_region], len(items), n_nodes)
    # The patches' boxes, one coordinate at a time: (F,) gathers of the
    # corners, where (F, 3) tables of them took a gigabyte on a city. The
    # corners' node numbers, in patch order, are gathered once for the three.
    order = np.argsort(patch, kind="stable")
    bounds = np.searchsorted(patch[order], np.arange(n_patches + 1))
    lower = np.empty((n_patches, 3))
    upper = np.empty((n_patches, 3))
    corner_nodes = [faces[:, c].astype(index).take(order) for c in range(k)]
    for axis in range(3):
        coordinate = np.ascontiguousarray(world[:, axis])
        corners = [coordinate.take(nodes) for nodes in corner_nodes]
        lower[:, axis] = np.minimum.reduceat(functools.reduce(np.minimum, corners), bounds[:-1])
        upper[:, axis] = np.maximum.reduceat(functools.reduce(np.maximum, corners), bounds[:-1])
    # -0.0 + 0.0 is 0.0: a box is the same whichever of two equal zeros a
    # reduction keeps (the compiled twin's may keep the other).
    return first_face, order, bounds, items, shell, lower + 0.0, upper + 0.0


def _write_msh(path: Path, model: SurfaceModel, tri: SurfaceModel, world: np.ndarray,
               binary: bool = False, is_cancelled: CancelCheck | None = None) -> None:
    """gmsh 4.1, ASCII or binary, with the entity topology of :func:`_msh_topology`.

    ``tri`` is ``model.triangulated()``. All nodes are in one block on the
    first surface entity: node tags are global in gmsh, and each shared node
    is stored once. Element tags are triangle indices + 1, the elements of a
    patch in one block.
    """
    topology = _msh_topology(model, world, tri if tri is not model else None)
    check_cancel(is_cancelled)
    (_write_msh_binary if binary else _write_msh_ascii)(path, topology, world, is_cancelled)


def _write_msh_ascii(path: Path, topology: _MshTopology, world: np.ndarray,
                     is_cancelled: CancelCheck | None = None) -> None:
    """The text encoding: coordinates and entity boxes to 0.1 mm."""
    t = topology
    n_nodes, n_faces, n_patches = len(world), len(t.faces), len(t.patch_physical)
    lines = ["$MeshFormat", "4.1 0 8", "$EndMeshFormat",
             "$PhysicalNames", str(len(t.names)), *t.names, "$EndPhysicalNames",
             "$Entities", f"0 0 {n_patches} {len(t.bounding)}"]
    for p, physical in enumerate(t.patch_physical.tolist(), start=1):
        lines.append(f"{p} {_box(t.patch_box[p - 1])} 1 {physical} 0")
    for v, (physical, tags) in enumerate(zip(t.shell_physical.tolist(), t.bounding), start=1):
        lines.append(f"{v} {_box(t.shell_box[v - 1])} 1 {physical} {len(tags)} " + " ".join(map(str, tags.tolist())))
    lines.append("$EndEntities")
    lines += ["$Nodes", f"1 {n_nodes} 1 {n_nodes}", f"2 1 0 {n_nodes}"]
    with _opened(path, "wb", is_cancelled) as out:  # ASCII text, written as bytes (core.row_text)
        out.write(("\n".join(lines) + "\n").encode("ascii"))
        write_rows(out, "%d", np.arange(1, n_nodes + 1)[:, None])
        write_rows(out, "%.4f %.4f %.4f", world)
        out.write(b"$EndNodes\n$Elements\n")
        out.write(f"{n_patches} {n_faces} 1 {n_faces}\n".encode("ascii"))
        row_format = " ".join(["%d"] * (t.faces.shape[1] + 1))

        def elements(part: tuple[int, slice]) -> tuple[bytes, bytes]:
            """A block of a patch's elements' text, after the patch's head if it is its first."""
            p, rows = part
            members = t.face_order[rows]
            head = f"2 {p + 1} 2 {t.patch_start[p + 1] - t.patch_start[p]}\n" if rows.start == t.patch_start[p] else ""
            return head.encode("ascii"), encoded_block(row_format, np.column_stack(
                [members + 1, t.faces.take(members, axis=0) + 1]), n_faces)

        # Every patch's blocks in one stream, on the threads ahead of the writing (core.parallel).
        for head, text in map_ahead(elements, _patch_blocks(t)):
            out.write(head)
            out.write(text)
        out.write(b"$EndElements\n")


def _write_msh_binary(path: Path, topology: _MshTopology, world: np.ndarray,
                      is_cancelled: CancelCheck | None = None) -> None:
    """The same file in gmsh's binary encoding: little-endian ``int`` (4
    bytes), ``size_t`` (8) and ``double``; coordinates are written exactly,
    not rounded to 0.1 mm as in the text."""
    t = topology
    n_nodes, n_faces, n_patches = len(world), len(t.faces), len(t.patch_physical)
    size_t = np.dtype("<u8")
    # An entity's head: tag, box, one physical tag, the number of bounding
    # entities (none for a surface; a volume's follow its head).
    head = np.dtype([("tag", "<i4"), ("box", "<f8", (6,)), ("n_physical", size_t), ("physical", "<i4"),
                     ("n_bounding", size_t)])
    surfaces = np.zeros(n_patches, dtype=head)
    surfaces["tag"] = np.arange(1, n_patches + 1)
    surfaces["box"] = t.patch_box
    surfaces["n_physical"] = 1
    surfaces["physical"] = t.patch_physical
    with _opened(path, "wb", is_cancelled) as out:
        out.write(b"$MeshFormat\n4.1 1 8\n" + np.array(1, "<i4").tobytes() + b"\n$EndMeshFormat\n")
        out.write(("\n".join(["$PhysicalNames", str(len(t.names)), *t.names, "$EndPhysicalNames"]) + "\n")
                  .encode("ascii"))
        out.write(b"$Entities\n" + np.array([0, 0, n_patches, len(t.bounding)], size_t).tobytes())
        out.write(surfaces.tobytes())
        for v, (physical, tags) in enumerate(zip(t.shell_physical.tolist(), t.bounding), start=1):
            out.write(np.array((v, t.shell_box[v - 1], 1, physical, len(tags)), dtype=head).tobytes())
            out.write(tags.astype("<i4").tobytes())
        out.write(b"\n$EndEntities\n$Nodes\n")
        out.write(np.array([1, n_nodes, 1, n_nodes], size_t).tobytes())
        out.write(np.array([2, 1, 0], "<i4").tobytes() + np.array(n_nodes, size_t).tobytes())
        out.write(np.arange(1, n_nodes + 1, dtype=size_t).tobytes())
        out.write(np.ascontiguousarray(world, dtype="<f8").tobytes())
        out.write(b"\n$EndNodes\n$Elements\n")
        out.write(np.array([n_patches, n_faces, 1, n_faces], size_t).tobytes())

        def elements(part: tuple[int, slice]) -> tuple[bytes, np.ndarray]:
            """Rows (tag, node, node, node) of a block of a patch's faces, after the patch's head if it is its first."""
            p, rows = part
            start, stop = t.patch_start[p], t.patch_start[p + 1]
            head = np.array([2, p + 1, 2], "<i4").tobytes() + np.array(stop - start, size_t).tobytes() \
                if rows.start == start else b""
            members = t.face_order[rows]
            block = np.empty((len(members), t.faces.shape[1] + 1), dtype=size_t)
            block[:, 0] = members + 1
            block[:, 1:] = t.faces.take(members, axis=0) + 1
            return head, block

        # _ROWS at a time, on the threads ahead of the writing (a table of
        # them all took 310 MB on the 1 km city).
        for head, block in map_ahead(elements, _patch_blocks(t)):
            out.write(head)
            out.write(block.data)
        out.write(b"\n$EndElements\n")


def _patch_blocks(topology: _MshTopology) -> list[tuple[int, slice]]:
    """Every patch's faces (rows of ``face_order``) in blocks of at most ``_ROWS``, patch by patch."""
    start = topology.patch_start.tolist()
    return [(p, slice(first, min(first + _ROWS, start[p + 1])))
            for p in range(len(start) - 1) for first in range(start[p], start[p + 1], _ROWS)]


def _box(box: np.ndarray) -> str:
    """An entity's box (lower corner, upper corner) as gmsh's text has it."""
    return " ".join(f"{value:.4f}" for value in box.tolist())


def _linked_parts(item: np.ndarray, group: np.ndarray, node: np.ndarray, n_items: int,
                  n_nodes: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Connected parts of items linked through the (group, node) pairs they have.

    Parameters
    ----------
    item, group, node : ndarray of int (L,)
        The links: item ``item[i]`` has the pair ``(group[i], node[i])``.
    n_items, n_nodes : int

    Returns
    -------
    part : ndarray of int (n_items,)
        Part of every item, numbered in the order of their first item.
    pair : ndarray of int64 (V,)
        The distinct pairs, as ``group * n_nodes + node``.
    pair_part : ndarray of int (V,)
        The part of each pair.

    Examples
    --------
    Three triangles, the first two sharing node 2, in group 0; the third
    shares node 4 with the second but in another group:

    >>> tri = np.array([[0, 1, 2], [2, 3, 4], [4, 5, 6]])
    >>> part, pair, _ = _linked_parts(np.repeat(np.arange(3), 3), np.repeat([0, 0, 1], 3), tri.ravel(), 3, 7)
    >>> part.tolist(), len(pair)
    ([0, 0, 1], 8)
    """
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    # Most nodes are in one group only (inside an interface, away from the
    # lines where regions meet): their pair is the node itself. Only the
    # links at the other nodes are numbered by a sort (of all the links, it
    # took most of the time on a city).
    node_group = np.zeros(n_nodes, dtype=group.dtype)
    node_group[node] = group  # any one of each node's groups
    mixed = np.zeros(n_nodes, dtype=bool)
    mixed[node[group != node_group[node]]] = True
    at_mixed = np.flatnonzero(mixed[node])
    mixed_pair, mixed_vertex = np.unique(group[at_mixed].astype(np.int64) * n_nodes + node[at_mixed],
                                         return_inverse=True)
    size = n_items + n_nodes + len(mixed_pair)
    # Graph vertices: the items, the nodes, then the mixed pairs. 32-bit
    # indices where they fit (the graph's own index type: no copy of it).
    index = np.int32 if size < 2**31 else np.int64
    vertex = node.astype(index)
    vertex[at_mixed] = n_nodes + mixed_vertex.ravel()
    vertex += n_items
    # Items and pairs in one bipartite graph; the items are its first
    # vertices, so its parts are numbered in the order of their first item.
    # Built as the float CSR matrix the search works on (a conversion would
    # copy it); links sorted by item (a face's corners) are its rows as they are.
    ones = np.ones(len(item))
    if np.all(item[1:] >= item[:-1]):
        indptr = np.full(size + 1, len(item), dtype=index)
        indptr[0] = 0
        indptr[1:n_items + 1] = np.cumsum(np.bincount(item, minlength=n_items))
        graph = csr_matrix((ones, vertex, indptr), shape=(size, size))
    else:
        graph = csr_matrix((ones, (item, vertex)), shape=(size, size))
    del vertex
    _, labels = connected_components(graph, directed=False)
    plain = np.zeros(n_nodes, dtype=bool)
    plain[node] = True
    plain = np.flatnonzero(plain & ~mixed)
    pair = np.concatenate([node_group[plain].astype(np.int64) * n_nodes + plain, mixed_pair])
    pair_part = np.concatenate([labels[n_items + plain], labels[n_items + n_nodes:]])
    return labels[:n_items], pair, pair_part

