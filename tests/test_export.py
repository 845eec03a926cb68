"""Mesh files: every format reads back (with other libraries) as closed,
conforming surfaces, and gmsh builds a valid tetrahedral mesh from the .msh."""
import re

import numpy as np
import pytest

from core.pipeline import ReconstructionParams, reconstruct_mesh, reconstruct_point_cloud, reconstruct_points
from core.topology import check_surface


@pytest.fixture(scope="module")
def result(district):
    params = ReconstructionParams(voxel_size=2.0, extent=district.district.extent)
    return reconstruct_point_cloud(district.laz, params=params)


def read_obj_groups(path):
    vertices, groups, current = [], {}, None
    with open(path) as obj:
        for line in obj:
            if line.startswith("v "):
                vertices.append([float(x) for x in line.split()[1:]])
            elif line.startswith("g "):
                current = line.split()[1]
                groups[current] = []
            elif line.startswith("f "):
                groups[current].append([int(x) - 1 for x in line.split()[1:]])
    return np.array(vertices), {k: np.array(v) for k, v in groups.items()}


def test_obj_has_one_closed_group_per_region(result, tmp_path):
    path = result.write_mesh(tmp_path / "city.obj")
    vertices, groups = read_obj_groups(path)
    assert set(groups) == {f"block_{b}" for b in result.blocks.block_id} | {"ground", "air"}
    for name, faces in groups.items():
        assert check_surface(faces).ok, name
    assert np.allclose(vertices, result.grid.to_world(result.mesh.nodes), atol=1e-4)


def test_text_formats_are_the_percent_operators(result, tmp_path, monkeypatch):
    """.obj and text .msh rows come from core.row_text: byte for byte the
    text of Python's % operator, row by row."""
    from core import export

    written = {}
    for name in ("a.obj", "a.msh"):
        written[name] = result.write_mesh(tmp_path / name).read_bytes()

    def operator_rows(out, row_format, rows):
        out.write(((row_format + "\n") * len(rows) % tuple(rows.ravel().tolist())).encode("ascii"))

    monkeypatch.setattr(export, "write_rows", operator_rows)
    for name in ("a.obj", "a.msh"):
        by_operator = result.write_mesh(tmp_path / ("b" + name[1:])).read_bytes()
        assert len(by_operator) > 10_000 and written[name] == by_operator, name


def test_stl_solids_are_watertight_for_trimesh(result, tmp_path):
    trimesh = pytest.importorskip("trimesh")
    path = result.write_mesh(tmp_path / "city.stl")
    scene = trimesh.load(path, force="scene")
    assert len(scene.geometry) == len(result.blocks) + 2
    for name, mesh in scene.geometry.items():
        assert mesh.is_watertight and mesh.is_winding_consistent, name
        assert mesh.volume > 0, name  # outward normals
    # Every facet of every region in turn: its corners to 0.1 mm, its unit normal to 1e-6.
    from core.export import _regions

    triangles = result.mesh_triangles
    faces, _ = triangles.closed_surfaces(_regions(triangles))
    corners = result.grid.to_world(triangles.nodes)[faces]
    text = path.read_text()
    written = np.array(re.findall(r"vertex (\S+) (\S+) (\S+)", text), dtype=float).reshape(-1, 3, 3)
    assert written.shape == corners.shape and np.abs(written - corners).max() <= 0.5e-4 + 1e-6
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    assert np.abs(np.array(re.findall(r"facet normal (\S+) (\S+) (\S+)", text), dtype=float) - normal).max() <= 1e-6


def test_vtu_and_ply_carry_the_regions(result, tmp_path):
    meshio = pytest.importorskip("meshio")
    vtu = meshio.read(result.write_mesh(tmp_path / "city.vtu"))
    a, b = vtu.cell_data["region_a"][0], vtu.cell_data["region_b"][0]
    assert len(a) == 2 * len(result.mesh.quads)     # every interface face once, as two triangles
    assert set(np.unique(vtu.cell_data["block_id"][0])) == set(result.blocks.block_id) | {-1}
    assert (a != b).all()
    # Exactly the triangles, their nodes and regions (core.vtu: 32-bit node numbers, zlib blocks).
    triangles = result.mesh_triangles
    assert np.array_equal(vtu.points, result.grid.to_world(triangles.nodes))
    assert vtu.cells[0].type == "triangle" and np.array_equal(vtu.cells[0].data, triangles.quads)
    assert np.array_equal(np.column_stack([a, b]), triangles.regions)
    trimesh = pytest.importorskip("trimesh")
    ply = trimesh.load(result.write_mesh(tmp_path / "city.ply"), process=False)
    region = np.asarray(ply.metadata["_ply_raw"]["face"]["data"]["region"]).ravel()
    assert set(np.unique(region)) == set(result.blocks.block_id) | {-1, -2}
    # Every node as it is, every face of every region's closed surface (written in blocks of rows).
    faces, labels = result.mesh_triangles.closed_surfaces(sorted(set(region.tolist()), key=lambda r: (r < 0, abs(r))))
    assert len(faces) > 65536 and np.array_equal(ply.faces, faces) and np.array_equal(region, labels)
    assert np.array_equal(ply.vertices, result.grid.to_world(result.mesh.nodes))
    assert check_surface(np.asarray(ply.faces)[region == -2]).ok  # the air, closed


@pytest.mark.parametrize("switch", ["0", "always"])
def test_closed_surfaces_are_the_closed_surface_of_each_region(result, switch, monkeypatch, compiled):
    """The one-sort grouping the writers use gives each region's faces, in
    order and orientation, as a scan of all faces per region does: numpy's
    stable sort, and the compiled counting sort (core.surface_kernel)."""
    from core.export import _grouped_surfaces, _regions

    monkeypatch.setenv("URBANVOX_JIT", switch)
    if switch == "always":
        compiled("surface_kernel")
    for model in (result.mesh, result.mesh.triangulated()):
        regions = _regions(model)[::-1]  # any order asked for is kept
        faces, labels = model.closed_surfaces(regions)
        expected = [model.closed_surface(r) for r in regions]
        assert np.array_equal(faces, np.concatenate(expected))
        assert np.array_equal(labels, np.concatenate([np.full(len(f), r) for f, r in zip(expected, regions)]))
        grouped, bounds = _grouped_surfaces(model, regions)
        for i, faces_of_region in enumerate(expected):
            assert np.array_equal(grouped[bounds[i]:bounds[i + 1]], faces_of_region)


def test_write_is_atomic_and_rejects_unknown_formats(result, tmp_path):
    from core.errors import UrbanvoxError
    with pytest.raises(UrbanvoxError, match="Unknown mesh format"):
        result.write_mesh(tmp_path / "city.dxf")
    assert list(tmp_path.iterdir()) == []


def gmsh_volume_mesh(msh_path):
    """Tetrahedra per physical volume and the minimum scaled Jacobian, meshing
    each region inside its surfaces as written (no repair, no surface remesh)."""
    gmsh = pytest.importorskip("gmsh")
    gmsh.initialize(["-nt", "1"])
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("Mesh.Algorithm3D", 10)  # HXT: fast, and strict about the input
        gmsh.open(str(msh_path))
        # A volume of the model bounded by its interfaces, as written; gmsh
        # meshes the inside of each surface loop without touching the surfaces.
        meshed_as = {}
        for _, tag in gmsh.model.getEntities(3):
            boundary = gmsh.model.getBoundary([(3, tag)], oriented=False)
            loop = gmsh.model.geo.addSurfaceLoop([abs(s) for _, s in boundary])
            meshed_as[tag] = gmsh.model.geo.addVolume([loop])
        gmsh.model.geo.synchronize()
        gmsh.model.mesh.generate(3)
        counts, worst = {}, np.inf
        for _, group in gmsh.model.getPhysicalGroups(3):
            name = gmsh.model.getPhysicalName(3, group)
            total = 0
            for entity in gmsh.model.getEntitiesForPhysicalGroup(3, group):
                for volume in (entity, meshed_as[entity]):
                    _, element_tags, _ = gmsh.model.mesh.getElements(3, volume)
                    tags = np.concatenate(element_tags) if element_tags else np.zeros(0)
                    total += len(tags)
                    if len(tags):
                        worst = min(worst, gmsh.model.mesh.getElementQualities(tags, "minSICN").min())
            counts[name] = total
        return counts, worst
    finally:
        gmsh.finalize()


def test_gmsh_meshes_air_and_every_block_of_the_district(result, tmp_path):
    counts, worst = gmsh_volume_mesh(result.write_mesh(tmp_path / "city.msh"))
    assert set(counts) == {f"block_{b}" for b in result.blocks.block_id} | {"ground", "air"}
    assert all(n > 0 for n in counts.values()), counts
    assert worst > 0  # no inverted tetrahedron


def test_gmsh_meshes_the_zurich_stl(shared_data, tmp_path):
    stl = shared_data / "cityjson" / "zurich_subset_lod2_buildings.stl"
    if not stl.exists():
        pytest.skip("Zurich STL not in the shared data")
    # 49 buildings scattered over 9 x 10 km: one grid (one ground, one air shell) per cluster.
    zurich = reconstruct_mesh(stl, crs="EPSG:2056", params=ReconstructionParams(voxel_size=2.0))
    assert len(zurich.blocks) >= 45
    counts, worst = gmsh_volume_mesh(zurich.write_mesh(tmp_path / "zurich.msh"))
    assert len(counts) == len(zurich.blocks) + 2
    assert all(n > 0 for n in counts.values()), counts
    assert worst > 0


def test_preview_png(result, tmp_path, monkeypatch, compiled):
    """A picture, the same with the compiled depth buffer and without."""
    pytest.importorskip("matplotlib")  # QGIS ships it; a bare venv of the core may not
    compiled("preview_kernel")
    monkeypatch.setenv("URBANVOX_JIT", "always")
    path = result.write_preview(tmp_path / "city.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert path.stat().st_size > 20_000
    monkeypatch.setenv("URBANVOX_JIT", "0")
    assert result.write_preview(tmp_path / "numpy.png").read_bytes() == path.read_bytes()


def test_preview_leaves_matplotlib_as_the_host_had_it(result, tmp_path):
    """The picture is drawn on a figure of its own: QGIS, other plugins or a
    notebook keep their backend and their open figures (pyplot's switch to
    Agg closed every figure, and the picture is drawn on a thread of its own
    in QGIS, where pyplot's global state is shared with the GUI's)."""
    matplotlib = pytest.importorskip("matplotlib")
    from matplotlib import pyplot as plt

    backend = matplotlib.get_backend()
    try:
        matplotlib.use("svg")
        figure = plt.figure()
        result.write_preview(tmp_path / "city.png")
        assert matplotlib.get_backend() == "svg"
        assert plt.get_fignums() == [figure.number]
    finally:
        plt.close("all")
        matplotlib.use(backend)


@pytest.mark.parametrize("name,binary", [("city.obj", False), ("city.stl", False), ("city.ply", False),
                                         ("city.msh", False), ("city.msh", True)])
def test_a_cancel_while_the_mesh_is_written_stops_it_and_leaves_no_file(result, tmp_path, monkeypatch, name, binary):
    """Blocks of 500 rows: the cancel, said at the writer's fifth check, stops it within the file
    (Cancelled), and neither the file nor its temporary is left; without a cancel the checks are
    made all along and the file is the one written without them."""
    from core import export, row_text
    from core.errors import Cancelled

    monkeypatch.setattr(export, "_ROWS", 500)
    monkeypatch.setattr(row_text, "_BLOCK", 500)
    checks = []
    whole = result.write_mesh(tmp_path / ("whole-" + name), binary=binary,
                              is_cancelled=lambda: checks.append(1) and False)
    assert len(checks) > 20 and whole.read_bytes() == result.write_mesh(tmp_path / name, binary=binary).read_bytes()
    (tmp_path / name).unlink()
    checks.clear()
    with pytest.raises(Cancelled):
        result.write_mesh(tmp_path / name, binary=binary, is_cancelled=lambda: len(checks.append(1) or checks) >= 5)
    assert len(checks) == 5 and sorted(p.name for p in tmp_path.iterdir()) == ["whole-" + name]


def test_a_cancel_while_the_vtu_is_compressed_stops_it_and_leaves_no_file(result, tmp_path, monkeypatch):
    """The .vtu's blocks are compressed on the threads, a cancel checked
    before each: said at the fifth check, the others stop at theirs, and
    neither the file nor its temporary is left."""
    from core import vtu
    from core.errors import Cancelled

    monkeypatch.setattr(vtu, "BLOCK_BYTES", 4096)
    checks = []
    whole = result.write_mesh(tmp_path / "whole.vtu", is_cancelled=lambda: checks.append(1) and False)
    every = len(checks)
    assert every > 200 and whole.read_bytes() == result.write_mesh(tmp_path / "city.vtu").read_bytes()
    (tmp_path / "city.vtu").unlink()
    checks.clear()
    with pytest.raises(Cancelled):
        result.write_mesh(tmp_path / "city.vtu", is_cancelled=lambda: len(checks.append(1) or checks) >= 5)
    assert len(checks) < every // 2 and sorted(p.name for p in tmp_path.iterdir()) == ["whole.vtu"]


def test_a_cancel_before_the_preview_is_drawn_leaves_no_picture(result, tmp_path):
    from core.errors import Cancelled

    checks = []
    with pytest.raises(Cancelled):
        result.write_preview(tmp_path / "city.png", is_cancelled=lambda: len(checks.append(1) or checks) >= 2)
    assert len(checks) == 2 and list(tmp_path.iterdir()) == []


def _face_parts(faces, n_nodes):
    """Parts of faces connected through shared nodes, numbered by first face (reference)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    rows = np.repeat(np.arange(len(faces)), faces.shape[1])
    size = len(faces) + n_nodes
    graph = coo_matrix((np.ones(len(rows)), (rows, len(faces) + faces.ravel())), shape=(size, size))
    labels = connected_components(graph, directed=False)[1][:len(faces)]
    return np.unique(labels, return_inverse=True)[1].ravel()


def _reference_entities(model):
    """gmsh entities as first written: one search per interface and per region."""
    from core.export import _regions

    tri = model.triangulated()
    pairs = np.sort(tri.regions, axis=1)
    interfaces, which = np.unique(pairs, axis=0, return_inverse=True)
    which = which.ravel()
    patch = np.empty(len(pairs), dtype=np.int64)
    patch_interface = []
    for i in range(len(interfaces)):
        sel = np.flatnonzero(which == i)
        labels = _face_parts(tri.quads[sel], len(tri.nodes))
        patch[sel] = len(patch_interface) + labels
        patch_interface += [i] * (labels.max() + 1)
    shells = []
    for r in _regions(tri):
        touching = np.flatnonzero((interfaces[patch_interface] == r).any(axis=1))
        sel = np.flatnonzero(np.isin(patch, touching))
        labels = _face_parts(tri.quads[sel], len(tri.nodes))
        for shell in range(labels.max() + 1):
            own = np.unique(patch[sel[labels == shell]])
            sign = np.where(interfaces[np.asarray(patch_interface)[own], 0] == r, 1, -1)
            shells.append((r, (sign * (own + 1)).tolist()))
    return [i + 1 for i in patch_interface], shells


def _msh_entities(path, regions):
    """(physical surface of every surface entity, (region, bounding surfaces) of every volume)."""
    lines = path.read_text().split("$Entities\n")[1].split("$EndEntities")[0].splitlines()
    n_surfaces, n_volumes = map(int, lines[0].split()[2:])
    surfaces = [int(line.split()[8]) for line in lines[1:1 + n_surfaces]]
    volumes = []
    for line in lines[1 + n_surfaces:1 + n_surfaces + n_volumes]:
        field = line.split()
        volumes.append((regions[int(field[8]) - 1], [int(t) for t in field[10:]]))
    return surfaces, volumes


@pytest.fixture(scope="module")
def two(district):
    """Two copies of the district 400 m apart: two clusters, so the ground and
    the air have two shells each and every interface two patches or more."""
    from core.readers.las import read_point_clouds

    points = read_point_clouds([district.laz])
    shift = np.array([400.0, 0.0, 0.0])
    return reconstruct_points(np.concatenate([points.ground, points.ground + shift]),
                              np.concatenate([points.building, points.building + shift]), points.crs,
                              ReconstructionParams(voxel_size=4.0), airborne=True)


@pytest.mark.parametrize("switch", ["0", "always"])
def test_gmsh_entities_match_a_search_per_interface_and_region(two, tmp_path, switch, monkeypatch, compiled):
    """The numpy search (a graph of faces and nodes) and the compiled one
    (core.export_kernel) find the entities of a search per interface and region."""
    from core.export import _regions

    monkeypatch.setenv("URBANVOX_JIT", switch)
    if switch == "always":
        compiled("export_kernel")
    surfaces, volumes = _msh_entities(two.write_mesh(tmp_path / "two.msh"), _regions(two.mesh))
    expected_surfaces, expected_volumes = _reference_entities(two.mesh)
    assert surfaces == expected_surfaces
    assert volumes == expected_volumes
    assert sum(region == -1 for region, _ in volumes) == 2  # two ground shells


def _gmsh_contents(path):
    """What gmsh reads from a .msh: names, entities with their groups and
    boundaries, the elements of every surface, and the nodes by tag."""
    gmsh = pytest.importorskip("gmsh")
    gmsh.initialize(["-nt", "1"])
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(path))
        names = sorted((dim, tag, gmsh.model.getPhysicalName(dim, tag))
                       for dim, tag in gmsh.model.getPhysicalGroups())
        entities, elements = [], {}
        for dim, tag in gmsh.model.getEntities():
            boundary = [t for _, t in gmsh.model.getBoundary([(dim, tag)], combined=False, oriented=True)] \
                if dim == 3 else []
            entities.append((dim, tag, list(gmsh.model.getPhysicalGroupsForEntity(dim, tag)), boundary))
            if dim == 2:
                types, tags, nodes = gmsh.model.mesh.getElements(dim, tag)
                elements[tag] = (types.tolist(), [t.tolist() for t in tags], [n.tolist() for n in nodes])
        node_tags, coords, _ = gmsh.model.mesh.getNodes()
        order = np.argsort(node_tags)
        return names, entities, elements, node_tags[order], coords.reshape(-1, 3)[order]
    finally:
        gmsh.finalize()


def test_binary_msh_reads_as_the_text_one(two, tmp_path):
    text = _gmsh_contents(two.write_mesh(tmp_path / "two.msh"))
    binary_path = two.write_mesh(tmp_path / "two_binary.msh", binary=True)
    assert binary_path.read_bytes().startswith(b"$MeshFormat\n4.1 1 8\n")
    binary = _gmsh_contents(binary_path)
    names, entities, elements, node_tags, coords = binary
    assert names == text[0] and entities == text[1] and elements == text[2]
    ground = [tag for dim, tag, name in names if dim == 3 and name == "ground"]
    assert len(ground) == 1
    assert sum(dim == 3 and groups == ground for dim, _, groups, _ in entities) == 2  # two ground shells
    assert np.array_equal(node_tags, text[3])
    # The text rounds coordinates to 0.1 mm; the binary file has them exactly.
    world = two.mesh_triangles.nodes + two.grid.offset
    assert np.array_equal(coords, world)
    assert np.abs(text[4] - world).max() <= 5.0001e-5
    meshio = pytest.importorskip("meshio")
    assert sum(len(block.data) for block in meshio.read(binary_path).cells) == len(two.mesh_triangles.quads)


def test_msh_entities_found_on_the_quads_are_those_of_their_triangles(two, tmp_path):
    """The entity search runs on the quads (half the faces); the file must be
    the one the search on the triangles themselves writes."""
    from core.export import write_mesh

    for binary in (False, True):
        by_quads = write_mesh(tmp_path / "quads.msh", two.mesh, two.grid.offset, binary=binary,
                              triangles=two.mesh_triangles)
        by_triangles = write_mesh(tmp_path / "triangles.msh", two.mesh_triangles, two.grid.offset, binary=binary)
        assert by_quads.read_bytes() == by_triangles.read_bytes()
