"""Which buildings of a city model each block holds (core.block_buildings): the district's parts
as buildings of a CityJSON file against its truth blocks, tiled and single runs alike, parts
named by their building, and the share rule on hand-made columns."""
import json

import numpy as np

from core.block_buildings import LEAST_SHARE, block_buildings
from core.pipeline import ReconstructionParams, reconstruct_mesh
from core.readers.cityjson import read_cityjson
from core.readers.mesh import Triangles, read_triangles
from core.tiles import TileOptions

CRS_URL = "https://www.opengis.net/def/crs/EPSG/0/2056"


def _write(path, objects, vertices):
    path.write_text(json.dumps({"type": "CityJSON", "version": "2.0", "metadata": {"referenceSystem": CRS_URL},
                                "CityObjects": objects, "vertices": vertices}))
    return path


def _district_as_buildings(district, path):
    """Every part of the district a Building of its own ("<truth block>/<n>"), its triangles a
    MultiSurface; the terrain a TINRelief. Returns the path and each part's identifier."""
    objects, vertices, names = {}, [], []
    for n, (part, triangles) in enumerate(district.district.part_meshes()):
        name = f"{part.block}/{n}"
        first = len(vertices)
        vertices += triangles.reshape(-1, 3).tolist()
        objects[name] = {"type": "Building", "geometry": [{"type": "MultiSurface", "lod": "2.2", "boundaries": [
            [[first + 3 * t, first + 3 * t + 1, first + 3 * t + 2]] for t in range(len(triangles))]}]}
        names.append((part.block, name))
    terrain = read_triangles(district.ground_stl)
    first = len(vertices)
    vertices += terrain.vertices.tolist()
    objects["terrain"] = {"type": "TINRelief", "geometry": [{"type": "CompositeSurface", "lod": "2", "boundaries": [
        [face] for face in (terrain.faces + first).tolist()]}]}
    return _write(path, objects, vertices), names


def test_each_block_names_the_parts_of_its_truth_block(district, tmp_path):
    """The district's 60-odd parts as buildings: every block of the voxel model holds exactly the
    parts of one truth block (touching parts make one block), the truth blocks below the
    thresholds hold none and are counted in a warning; the same in 100 m tiles."""
    path, names = _district_as_buildings(district, tmp_path / "parts.city.json")
    params = ReconstructionParams(voxel_size=1.0, smoothing_iterations=0, project=False)
    result = reconstruct_mesh(path, params=params)
    truth = {}
    for block, name in names:
        truth.setdefault(block, set()).add(name)
    kept = {b.name for b in district.expected_blocks}
    assert len(result.blocks) == len(kept) > 40
    held = [set(ids) for ids in result.block_buildings]
    assert sorted(map(sorted, held)) == sorted(sorted(truth[name]) for name in kept)
    rows = result.block_rows()
    assert [row["n_buildings"] for row in rows] == [len(ids) for ids in held]
    assert all(row["building_ids"] == ";".join(sorted(ids)) for row, ids in zip(rows, held))
    dropped = sum(len(truth[b.name]) for b in district.blocks if b.below_thresholds)
    assert dropped > 0
    assert f"{dropped} of the city model's {len(names)} buildings are in no block" in " ".join(result.warnings)
    tiled = reconstruct_mesh(path, params=params, tiles=TileOptions(tile_size=100.0))
    assert tiled.blocks.volume.tolist() == result.blocks.volume.tolist()
    assert tiled.block_buildings == result.block_buildings


def test_parts_are_named_by_their_building(tmp_path):
    """A Building with only a LoD 0 footprint on the ground (as 3D BAG's) and its two
    BuildingParts (one a part of the other), and a lone BuildingInstallation: two buildings, each
    face owned by its root; the footprint changes no block."""
    box = [[0, 0, 0], [10, 0, 0], [10, 8, 0], [0, 8, 0], [0, 0, 6], [10, 0, 6], [10, 8, 6], [0, 8, 6]]
    shell = [[[0, 3, 2, 1]], [[4, 5, 6, 7]], [[0, 1, 5, 4]], [[1, 2, 6, 5]], [[2, 3, 7, 6]], [[3, 0, 4, 7]]]

    def solid(shift):
        return [{"type": "Solid", "lod": "2.2", "boundaries": [[[[i + shift for i in ring] for ring in face]
                                                                for face in shell]]}]

    vertices = box + [[x + 10, y, z] for x, y, z in box] + [[x + 40, y, z] for x, y, z in box]
    objects = {"house": {"type": "Building", "children": ["wing"],
                         "geometry": [{"type": "MultiSurface", "lod": "0", "boundaries": [[[0, 3, 2, 1]]]}]},
               "wing": {"type": "BuildingPart", "parents": ["house"], "children": ["annex"], "geometry": solid(0)},
               "annex": {"type": "BuildingPart", "parents": ["wing"], "geometry": solid(8)},
               "kiosk": {"type": "BuildingInstallation", "geometry": solid(16)}}
    city = read_cityjson(_write(tmp_path / "parts.city.json", objects, vertices))
    assert city.buildings.owner_ids == ("house", "kiosk")
    # The footprint's two triangles are the wing's floor's: dropped as repeated.
    assert np.bincount(city.buildings.owner).tolist() == [24, 12]
    params = ReconstructionParams(voxel_size=1.0, smoothing_iterations=0, project=False)
    result = reconstruct_mesh(tmp_path / "parts.city.json", params=params)
    assert result.block_buildings == [("house",), ("kiosk",)]
    assert not [w for w in result.warnings if "in no block" in w]
    del objects["house"]["geometry"]
    without = reconstruct_mesh(_write(tmp_path / "no_lod0.city.json", objects, vertices), params=params)
    assert without.blocks.volume.tolist() == result.blocks.volume.tolist()
    assert without.block_buildings == result.block_buildings


def _roofs(squares, owners):
    """Flat roofs, one per ((x0, y0), (x1, y1)) square, owned by ``owners``."""
    vertices, faces = [], []
    for (x0, y0), (x1, y1) in squares:
        n = len(vertices)
        vertices += [[x0, y0, 5], [x1, y0, 5], [x1, y1, 5], [x0, y1, 5]]
        faces += [[n, n + 1, n + 2], [n, n + 2, n + 3]]
    owner = np.repeat(owners, 2)
    return Triangles(np.array(vertices, float), np.array(faces), owner=owner,
                     owner_ids=tuple(f"b{k}" for k in range(max(owners) + 1)))


def test_a_building_is_in_every_block_holding_a_quarter_of_its_plan_area():
    """One building over eight 1 m columns, 2 m wide: its faces counted by centroid. Split 4:4
    between two blocks it is in both; split 7:1, only in the first; a column under two blocks
    (one above the other) counts for both; walls only count their own area."""
    building = _roofs([((x, 0), (x + 1, 2)) for x in range(8)], [0] * 8)
    columns = [(1, x, y) for x in range(4) for y in range(2)] + [(2, x, y) for x in range(4, 8) for y in range(2)]
    corner = np.zeros(2)
    assert block_buildings(building, np.array(columns), np.array([1, 2]), corner, 1.0) == ([("b0",), ("b0",)], 0)
    # Faces' centroids lie at y = 2/3 and 4/3: columns 0 and 1 across.
    columns = [(1, x, y) for x in range(7) for y in range(2)] + [(2, 7, y) for y in range(2)]
    assert 1 / 8 < LEAST_SHARE
    assert block_buildings(building, np.array(columns), np.array([2, 1]), corner, 1.0) == ([(), ("b0",)], 0)
    # In no block: counted; and with no block at all.
    assert block_buildings(building, np.array([(3, 20, 20)]), np.array([3]), corner, 1.0) == ([()], 1)
    assert block_buildings(building, np.empty((0, 3), np.int64), np.empty(0, np.int64), corner, 1.0) == ([], 1)
    # Stacked blocks 1 and 2 over all its columns, and a second building beside, in block 2 only.
    two = _roofs([((0, 0), (8, 2)), ((10, 0), (12, 2))], [0, 1])
    columns = ([(1, x, y) for x in range(8) for y in range(2)] + [(2, x, y) for x in range(12) for y in range(2)])
    assert block_buildings(two, np.array(columns), np.array([1, 2]), corner, 1.0) == ([("b0",), ("b0", "b1")], 0)
    # A wall (no plan area) in block 1's column.
    wall = Triangles(np.array([[0.2, 0.5, 0], [0.8, 0.5, 0], [0.5, 0.5, 3]]), np.array([[0, 1, 2]]),
                     owner=np.array([0]), owner_ids=("w",))
    assert block_buildings(wall, np.array([(1, 0, 0)]), np.array([1]), corner, 1.0) == ([("w",)], 0)
    # A mesh file names no buildings.
    plain = Triangles(two.vertices, two.faces)
    assert block_buildings(plain, np.array(columns), np.array([1, 2]), corner, 1.0) == ([(), ()], 0)


def test_an_stl_gives_no_building_fields(district):
    params = ReconstructionParams(voxel_size=2.0, smoothing_iterations=0, project=False)
    result = reconstruct_mesh(district.stl, crs=district.crs, params=params)
    assert result.block_buildings is None
    assert "building_ids" not in result.block_rows()[0] and "n_buildings" not in result.block_rows()[0]


def test_zurich_and_den_haag_buildings_are_one_per_block(shared_data):
    """Zurich's 49 buildings (161 parts) at 1 m: 49 blocks, each holding one of them, every
    building once. Den Haag's 4 (8 parts) at 0.5 m likewise."""
    for name, crs, voxel, count in (("zurich_subset_lod2.json", None, 1.0, 49), ("DH_01_subs.city.json",
                                                                                  "EPSG:7415", 0.5, 4)):
        path = shared_data / "cityjson" / name
        buildings = sorted(key for key, value in json.loads(path.read_text())["CityObjects"].items()
                           if value["type"] == "Building")
        result = reconstruct_mesh(path, crs=crs, params=ReconstructionParams(voxel_size=voxel, smoothing_iterations=0,
                                                                              project=False))
        assert len(buildings) == len(result.blocks) == count
        assert [len(ids) for ids in result.block_buildings] == [1] * count
        assert sorted(ids[0] for ids in result.block_buildings) == buildings
