"""Tests of the synthetic district: truth is exact, the data look like the real thing.

The analytic truth is cross-checked against independent estimates: grid integration
of ``surface_z - terrain_z``, the STL meshes cut by the terrain plane, and textbook
formulas for simple buildings.
"""

import doctest
import json
import time

import laspy
import numpy as np
import pytest
import shapely
import trimesh

from core import synthetic as syn
from core.synthetic import CRS_EPSG, DEFAULT_THRESHOLDS, ORIGIN, make_district

CELL = 0.1  # grid cells aligned with the 0.5 m design grid: axis-aligned edges are exact


@pytest.fixture(scope="module")
def district():
    return make_district()


@pytest.fixture(scope="module")
def blocks(district):
    return {b.name: b for b in district.blocks}


@pytest.fixture(scope="module")
def las(district, tmp_path_factory):
    path = tmp_path_factory.mktemp("las") / "district.laz"
    n = district.write_las(path)
    return n, laspy.read(path)


def _grid(district, b, pad=1.0):
    """Cell centres around a block and the surface there (terrain outside the extent)."""
    x0, y0, x1, y1 = shapely.from_wkt(b.footprint_wkt).bounds
    ix = np.arange(np.floor((x0 - pad - ORIGIN[0]) / CELL), np.ceil((x1 + pad - ORIGIN[0]) / CELL))
    iy = np.arange(np.floor((y0 - pad - ORIGIN[1]) / CELL), np.ceil((y1 + pad - ORIGIN[1]) / CELL))
    gx, gy = np.meshgrid(ORIGIN[0] + (ix + 0.5) * CELL, ORIGIN[1] + (iy + 0.5) * CELL,
                         indexing="ij")
    ex0, ey0, ex1, ey1 = district.extent
    inside = (gx > ex0) & (gx < ex1) & (gy > ey0) & (gy < ey1)
    t = district.terrain_z(gx, gy)
    return np.where(inside, district.surface_z(gx, gy), t), t


def _staircase_surface(z, t):
    """Surface area estimate for axis-aligned blocks: jumps are walls, the rest is roof."""
    wall, slopes = 0.0, []
    for ax in (0, 1):
        d = np.diff(z, axis=ax)
        jump = np.abs(d) > 0.3
        wall += np.abs(d[jump]).sum() * CELL
        g = np.where(jump, np.nan, d / CELL)
        # per cell: mean of the smooth one-sided slopes (ignores the jump side of a wall)
        pad = [(0, 0), (0, 0)]
        pad[ax] = (1, 0)
        back = np.pad(g, pad, constant_values=np.nan)
        pad[ax] = (0, 1)
        fwd = np.pad(g, pad, constant_values=np.nan)
        both = np.stack([back, fwd])
        count = (~np.isnan(both)).sum(axis=0)
        slopes.append(np.nansum(both, axis=0) / np.maximum(count, 1))
    roof = z > t + 1e-6
    factor = np.sqrt(1 + slopes[0] ** 2 + slopes[1] ** 2)
    return wall + (factor[roof] * CELL**2).sum()


def _surface_near(district, x, y, r=0.002):
    """Highest surface within ``r`` (LAS xy are stored to 1 mm: wall points may step out)."""
    return np.max([district.surface_z(x + dx, y + dy)
                   for dx, dy in ((0, 0), (r, 0), (-r, 0), (0, r), (0, -r))], axis=0)


# --- truth ---------------------------------------------------------------------------

def test_content_and_names(district, blocks):
    assert len(district.blocks) >= 30
    assert len(blocks) == len(district.blocks)  # unique names
    for name in ("rotated45", "tower", "courtyard", "row_houses", "intersecting_boxes",
                 "hip_roof", "gable_house_1", "shed", "border_cut"):
        assert name in blocks
    kinds = {p.roof for p in district._parts}
    assert kinds == {"flat", "gable", "hip"}
    assert sum(p.block == "row_houses" for p in district._parts) == 4
    assert sum(p.block == "intersecting_boxes" for p in district._parts) == 3
    assert any(p.angle == 45 for p in district._parts)


def test_volume_matches_grid_integration(district):
    for b in district.blocks:
        z, t = _grid(district, b)
        v = (z - t).sum() * CELL**2
        assert v == pytest.approx(b.volume, rel=1e-3), b.name


def test_surface_matches_staircase_estimate(district):
    for b in district.blocks:
        if b.name == "rotated45":  # staircase walls overestimate diagonal walls
            continue
        z, t = _grid(district, b)
        assert _staircase_surface(z, t) == pytest.approx(b.surface_area, rel=5e-3), b.name


def test_single_parts_match_mesh_cut_by_terrain(district, blocks):
    """Surface above the terrain of each closed single-part mesh equals the truth."""
    n_checked = 0
    normal = np.array([-syn.TERRAIN[1], -syn.TERRAIN[2], 1.0])
    for p, tris in district.part_meshes():
        b = blocks[p.block]
        if b.on_border or sum(q.block == p.block for q in district._parts) > 1:
            continue
        local = tris - np.array([ORIGIN[0], ORIGIN[1], 0.0])
        mesh = trimesh.Trimesh(**trimesh.triangles.to_kwargs(local))
        above = trimesh.intersections.slice_mesh_plane(mesh, normal, [0, 0, syn.TERRAIN[0]])
        assert above.area == pytest.approx(b.surface_area, rel=1e-9), b.name
        n_checked += 1
    assert n_checked >= 30


def test_textbook_formulas(blocks):
    b = blocks["tower"]
    assert (b.volume, b.footprint_area, b.surface_area) == pytest.approx(
        (144 * 60, 144, 144 + 48 * 60))
    b = blocks["rotated45"]  # flat box on a plane: A * h, walls P * h
    assert (b.volume, b.surface_area) == pytest.approx((160 * 9, 160 + 52 * 9))
    b = blocks["hip_roof"]  # box + hip roof W*H*(3L-W)/6
    assert b.volume == pytest.approx(20 * 12 * 7 + 12 * 4 * (3 * 20 - 12) / 6)
    assert b.top_z - b.ground_z == pytest.approx(b.height)
    b = blocks["gable_house_1"]
    assert b.volume == pytest.approx(14 * 9 * (6 + 3.5 / 2))
    # border: only x in [238, 250] of a 24 m gable counts; eave 9 m above terrain at x=250
    b = blocks["border_cut"]
    assert b.footprint_area == pytest.approx(12 * 16)
    assert b.volume == pytest.approx(12 * 16 * (9 + 0.02 * 6) + 12 * 16 * 4 / 2)
    roof = 2 * 12 * np.hypot(8, 4)
    walls = 24 * 9.12 + (16 * 9.24 + 32) + (16 * 9 + 32)  # incl. the cut face at x=250
    assert b.surface_area == pytest.approx(roof + walls)


def test_union_volume_of_intersecting_parts(district, blocks):
    parts = [p for p in district._parts if p.block == "intersecting_boxes"]
    alone = [syn.block_truth("x", [p])[0].volume for p in parts]
    assert max(alone) < blocks["intersecting_boxes"].volume < sum(alone) - 100


def test_footprints_centroids_and_flags(district, blocks):
    ext = shapely.box(*district.extent)
    for b in district.blocks:
        g = shapely.from_wkt(b.footprint_wkt)
        assert g.area == pytest.approx(b.footprint_area, rel=1e-9)
        assert (g.centroid.x, g.centroid.y) == pytest.approx(b.centroid, abs=1e-5)
        assert ext.covers(g)
        assert b.on_border == (b.name == "border_cut")
        assert b.height == pytest.approx(b.top_z - b.ground_z)
        corners = np.asarray(g.exterior.coords).T
        assert b.ground_z == pytest.approx(district.terrain_z(*corners).min())
        th = DEFAULT_THRESHOLDS
        low = b.height < th["min_height"] or b.footprint_area < th["min_footprint"] \
            or b.volume < th["min_volume"]
        assert b.below_thresholds == low
    low = {b.name for b in district.blocks if b.below_thresholds}
    assert low == {"shed", "low_kiosk", "tiny_hut"}
    shed = blocks["shed"]
    assert shed.height < 2.5 and shed.footprint_area < 10 and shed.volume < 20
    yard = shapely.from_wkt(blocks["courtyard"].footprint_wkt)
    assert len(yard.interiors) == 1
    x0, y0, x1, y1 = shapely.Polygon(yard.interiors[0]).bounds
    assert min(x1 - x0, y1 - y0) >= 12
    row = shapely.from_wkt(blocks["row_houses"].footprint_wkt)
    assert row.geom_type == "Polygon" and row.area == pytest.approx(36 * 11)


def test_blocks_are_separated(district):
    geoms = [shapely.from_wkt(b.footprint_wkt) for b in district.blocks]
    for i, a in enumerate(geoms):
        for b in geoms[i + 1:]:
            assert a.distance(b) >= 4.0


def test_deterministic_and_fast():
    t = time.perf_counter()
    a = make_district(0)
    assert time.perf_counter() - t < 2.0
    assert a.truth_table() == make_district(0).truth_table()
    c = make_district(1)
    assert c.truth_table() != a.truth_table()
    assert {b.name: b for b in c.blocks}["tower"] == {b.name: b for b in a.blocks}["tower"]
    assert len(c.blocks) >= 30


def test_surface_and_terrain_functions(district, blocks):
    x0, y0, x1, y1 = district.extent
    assert district.terrain_z(x0, y0) == pytest.approx(400.0)
    assert district.terrain_z(x1, y1) == pytest.approx(400 + 0.02 * 250 + 0.01 * 250)
    b = blocks["tower"]
    assert district.surface_z(*b.centroid) == pytest.approx(b.top_z)
    yard = shapely.from_wkt(blocks["courtyard"].footprint_wkt).interiors[0].centroid
    assert district.surface_z(yard.x, yard.y) == pytest.approx(district.terrain_z(yard.x, yard.y))
    xs = np.array([[x0, x1], [x0, x1]])
    assert district.surface_z(xs, xs * 0 + y0).shape == (2, 2)


# --- LAS -----------------------------------------------------------------------------

def test_las_header_and_classes(district, las):
    n, pc = las
    h = pc.header
    assert len(pc.points) == n
    assert (str(h.version), h.point_format.id) == ("1.4", 6)
    assert np.allclose(h.scales, 0.001)
    assert h.parse_crs().to_epsg() == CRS_EPSG
    assert np.allclose(h.mins[:2], district.extent[:2])
    assert np.allclose(h.maxs[:2], district.extent[2:])
    cls = np.asarray(pc.classification)
    assert set(np.unique(cls)) == {2, 5, 6, 7}
    assert (cls == 7).sum() == 36
    dz = np.asarray(pc.z) - _surface_near(district, np.asarray(pc.x), np.asarray(pc.y))
    facade = (cls == 6) & (dz < -0.2)
    assert abs((np.isin(cls, (2, 5, 6)) & ~facade).sum() / 250**2 - 12.0) < 0.1


def test_las_geometry(district, blocks, las):
    _, pc = las
    x, y, z = np.asarray(pc.x), np.asarray(pc.y), np.asarray(pc.z)
    cls = np.asarray(pc.classification)
    feet = shapely.union_all([shapely.from_wkt(b.footprint_wkt) for b in district.blocks])
    g = cls == 2
    # no ground under roofs (2 mm inset: coordinates are stored to 1 mm)
    assert not shapely.contains_xy(feet.buffer(-0.002), x[g], y[g]).any()
    assert np.abs(z[g] - district.terrain_z(x[g], y[g])).max() < 0.2
    # ground in the courtyard
    yard = shapely.Polygon(shapely.from_wkt(blocks["courtyard"].footprint_wkt).interiors[0])
    assert shapely.contains_xy(yard, x[g], y[g]).sum() > 1000
    # roof points on the roofs, a few facade points below them
    b6 = cls == 6
    dz = z[b6] - _surface_near(district, x[b6], y[b6])
    assert dz.max() < 0.15  # 6 sigma of the z noise: nothing above the roofs
    roof = np.abs(dz) < 0.1
    assert roof.sum() == pytest.approx(12.0 * feet.area, rel=0.03)
    # the crowns that overhang roofs leave holes: under a crown, class 6 is facade only
    for tx, ty, r, _ in district._trees:
        under = b6 & (np.hypot(x - ORIGIN[0] - tx, y - ORIGIN[1] - ty) < r - 0.01)
        pts = shapely.points(x[under], y[under])
        assert (shapely.distance(feet.boundary, pts) < 0.002).all()
    facade = dz < -0.5
    w = district._walls
    length = np.hypot(*(w[:, 2:4] - w[:, :2]).T)
    expected = syn.WALL_DENSITY * syn.wall_area(w[:, 6] - w[:, 4], w[:, 7] - w[:, 5], length).sum()
    assert 0.8 * expected < facade.sum() < 1.1 * expected
    # vegetation over some roofs: holes in the roof
    v = cls == 5
    assert shapely.contains_xy(feet, x[v], y[v]).sum() > 50
    assert (z[v] > district.surface_z(x[v], y[v]) + 0.3).all()
    # noise far from the surface
    n7 = cls == 7
    assert (np.abs(z[n7] - district.surface_z(x[n7], y[n7])) > 1.5).all()


def test_las_deterministic_and_options(district, tmp_path):
    a, b, c = tmp_path / "a.laz", tmp_path / "b.laz", tmp_path / "c.laz"
    district.write_las(a, density=1.0)
    district.write_las(b, density=1.0)
    district.write_las(c, density=1.0, seed=7)
    assert a.read_bytes() == b.read_bytes() != c.read_bytes()
    p = tmp_path / "plain.las"
    n = district.write_las(p, density=1.0, crs=False)
    pc = laspy.read(p)
    assert len(pc.points) == n and pc.header.point_format.id == 6
    assert pc.header.parse_crs() is None
    assert p.read_bytes()[:4] == b"LASF"


# --- STL -----------------------------------------------------------------------------

def _read_stl(path):
    raw = path.read_bytes()
    n = int(np.frombuffer(raw, "<u4", 1, 80)[0])
    dt = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    assert len(raw) == 84 + n * dt.itemsize
    return np.frombuffer(raw, dt, n, 84)


def test_stl_file(district, blocks, tmp_path):
    path = tmp_path / "b.stl"
    n = district.write_stl(path)
    rec = _read_stl(path)
    assert len(rec) == n and rec["v"].dtype == np.float32
    v = rec["v"].astype(np.float64)
    assert v[..., 0].min() > 2.5e6 and v[..., 1].min() > 1.1e6
    mesh = trimesh.load(path)
    assert not mesh.is_watertight and not mesh.is_winding_consistent
    path2 = tmp_path / "b2.stl"
    district.write_stl(path2)
    assert path.read_bytes() == path2.read_bytes()
    # inner faces: triangles strictly inside a block's solid
    c = v.mean(axis=1)
    inner = {}
    for b in district.blocks:
        g = shapely.from_wkt(b.footprint_wkt).buffer(-0.3)
        m = shapely.contains_xy(g, c[:, 0], c[:, 1])
        m &= (c[:, 2] > district.terrain_z(c[:, 0], c[:, 1]) + 0.3)
        m &= (c[:, 2] < district.surface_z(c[:, 0], c[:, 1]) - 0.3)
        inner[b.name] = int(m.sum())
    assert inner["intersecting_boxes"] > 0 and inner["row_houses"] > 0 and inner["courtyard"] > 0
    assert sum(k for name, k in inner.items()
               if name not in ("intersecting_boxes", "row_houses", "courtyard")) == 0
    # the border building is not clipped in the STL
    assert v[..., 0].max() > district.extent[2] + 10


def test_stl_parts_realism(district):
    seen = set()
    for p, tris in district.part_meshes():
        m = trimesh.Trimesh(**trimesh.triangles.to_kwargs(tris - [ORIGIN[0], ORIGIN[1], 0]))
        assert m.is_watertight == p.floor, p
        assert m.is_winding_consistent == (p.winding != "mixed"), p
        if p.floor and p.winding == "ok":
            assert m.volume > 0
        if p.floor and p.winding == "inverted":
            assert m.volume < 0
        seen.add((p.floor, p.winding))
    assert {(True, "ok"), (False, "ok"), (True, "inverted"), (True, "mixed")} <= seen


def test_ground_stl(district, tmp_path):
    path = tmp_path / "g.stl"
    n = district.write_ground_stl(path)
    rec = _read_stl(path)
    assert n == len(rec) == 2 * 25 * 25
    v = rec["v"].reshape(-1, 3).astype(np.float64)
    assert np.allclose(v[:, 2], district.terrain_z(v[:, 0], v[:, 1]), atol=1e-4)
    bounds = (v[:, 0].min(), v[:, 1].min(), v[:, 0].max(), v[:, 1].max())
    assert bounds == pytest.approx(district.extent)
    assert (rec["n"][:, 2] > 0.99).all()
    tilt = np.sqrt(1 + 0.02**2 + 0.01**2)
    assert trimesh.load(path).area == pytest.approx(250 * 250 * tilt, rel=1e-6)


# --- CLI and docs --------------------------------------------------------------------

def test_cli(tmp_path, district):
    assert syn.main([str(tmp_path)]) == 0
    for f in ("district.laz", "district.stl", "district_ground.stl", "truth.json"):
        assert (tmp_path / f).stat().st_size > 0
    doc = json.loads((tmp_path / "truth.json").read_text())
    assert doc["crs_epsg"] == CRS_EPSG and doc["blocks"] == district.truth_table()
    assert syn.main([]) == 2


def test_doctests():
    assert doctest.testmod(syn).failed == 0
