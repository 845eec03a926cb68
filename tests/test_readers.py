"""Tests of core/readers/las.py and core/readers/mesh.py (core/crs.py: tests/test_crs.py).

Synthetic files are written into tmp_path; the real files of ../shared/data are
used when present and the tests skip cleanly otherwise.
"""

from __future__ import annotations

import glob
import struct
import time
from pathlib import Path

import laspy
import numpy as np
import pyproj
import pytest
import trimesh

from core.errors import Cancelled, UrbanvoxError
from core.readers import las as las_module
from core.readers.las import parse_classes, read_point_clouds
from core.readers.mesh import MESH_SUFFIXES, Triangles, base_points, edge_counts, read_triangles

@pytest.fixture(params=["numpy", "compiled"], autouse=True)
def chunk_sorting(request, monkeypatch, compiled):
    """Every test reads with numpy's sorting of the chunks and with the kernel's."""
    from core import jit

    if request.param == "numpy":
        monkeypatch.setattr(jit, "ready", lambda name: False)
    else:
        compiled("las_kernel")
        monkeypatch.setattr(jit, "ready", lambda name: True)
    return request.param


def data_file(shared_data: Path, relative: str) -> Path:
    """A file of the real test data (fixture ``shared_data`` of conftest.py); skip if absent."""
    path = shared_data / relative
    if not path.exists():
        pytest.skip(f"real test data {relative} not available")
    return path


# ----------------------------------------------------------------------------- helpers


def write_las(path, xyz, classes, crs=None, version="1.4", point_format=6, withheld=None):
    """Write a small LAS/LAZ file with laspy (LAZ when the suffix is .laz)."""
    header = laspy.LasHeader(version=version, point_format=point_format)
    header.scales = np.array([0.001, 0.001, 0.001])
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    header.offsets = xyz.min(axis=0) if len(xyz) else np.zeros(3)
    if crs is not None:
        header.add_crs(pyproj.CRS(crs))
    las = laspy.LasData(header)
    las.x, las.y, las.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    las.classification = np.asarray(classes, dtype=np.uint8)
    if withheld is not None:
        las.withheld = np.asarray(withheld, dtype=np.uint8)
    las.write(str(path))
    return path


def town(n=300, seed=0, x0=85000.0, y0=447000.0):
    """Ground on a plane, one block of roof points, some vegetation and a vendor class."""
    rng = np.random.default_rng(seed)
    xy = rng.random((n, 2)) * 50 + (x0, y0)
    z = np.full(n, 1.0)
    classes = np.full(n, 2)
    roof = (xy[:, 0] - x0 < 20) & (xy[:, 1] - y0 < 20)
    z[roof], classes[roof] = 12.0, 6
    classes[::17] = 5  # high vegetation
    classes[::29] = 1
    return np.column_stack([xy, z]), classes


# ----------------------------------------------------------------------------- parse_classes


@pytest.mark.parametrize(
    "text, expected",
    [("2", (2,)), ("2,9", (2, 9)), ("2 9", (2, 9)), (" 2 ; 9 ,", (2, 9)), ([2, 9], (2, 9)), ((6, 6), (6,))],
)
def test_parse_classes(text, expected):
    assert parse_classes(text) == expected


@pytest.mark.parametrize("text", ["", "ground", "2,x", "300", "-1", [2.5], []])
def test_parse_classes_rejects(text):
    with pytest.raises(UrbanvoxError):
        parse_classes(text, "GROUND_CLASSES")


# ----------------------------------------------------------------------------- LAS reading


@pytest.mark.parametrize(
    "version, fmt, suffix", [("1.2", 3, ".las"), ("1.2", 1, ".laz"), ("1.4", 6, ".laz"), ("1.4", 8, ".las")]
)
def test_read_synthetic_all_formats(tmp_path, version, fmt, suffix):
    xyz, classes = town()
    classes[::31] = 26 if fmt < 6 else 64  # vendor code (fits 5 bits in formats 0-5)
    path = write_las(tmp_path / f"t{suffix}", xyz, classes, crs="EPSG:28992", version=version, point_format=fmt)
    pts = read_point_clouds(path)
    assert pts.crs.to_epsg() == 28992
    assert pts.n_points == len(xyz)
    assert len(pts.ground) == (classes == 2).sum() and len(pts.building) == (classes == 6).sum()
    assert pts.ground.dtype == np.float64 and pts.ground.shape[1] == 3
    np.testing.assert_allclose(np.sort(pts.building[:, 0]), np.sort(xyz[classes == 6, 0]), atol=1e-3)
    assert np.all(pts.building[:, 2] == pytest.approx(12.0))
    expected = dict(zip(*[a.tolist() for a in np.unique(classes, return_counts=True)]))
    assert pts.class_counts == expected
    vendor = 26 if fmt < 6 else 64
    assert any(f"class {vendor} (non-standard)" in w for w in pts.warnings)


def test_other_classes_are_not_building(tmp_path):
    xyz = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 9], [3, 0, 9], [4, 0, 9], [5, 0, 9]], dtype=float)
    classes = [2, 2, 5, 7, 9, 1]
    pts = read_point_clouds(write_las(tmp_path / "a.las", xyz, classes, crs="EPSG:2154"))
    assert len(pts.ground) == 2 and len(pts.building) == 0
    assert any("no building block" in w for w in pts.warnings)
    assert any("building classes [6] absent" in w for w in pts.warnings)


def test_custom_classes_and_text(tmp_path):
    xyz, classes = town()
    classes[:10] = 9  # water counted as ground
    path = write_las(tmp_path / "a.las", xyz, classes, crs="EPSG:28992")
    pts = read_point_clouds([path], ground_classes="2,9", building_classes="6")
    assert len(pts.ground) == np.isin(classes, [2, 9]).sum()
    pts = read_point_clouds(path, building_classes="")
    assert len(pts.building) == 0


def test_overlapping_classes_rejected(tmp_path):
    xyz, classes = town()
    path = write_las(tmp_path / "a.las", xyz, classes, crs="EPSG:28992")
    with pytest.raises(UrbanvoxError, match=r"\[6\].*both"):
        read_point_clouds(path, ground_classes="2,6", building_classes="6")


def test_empty_file(tmp_path):
    path = write_las(tmp_path / "empty.las", np.empty((0, 3)), [], crs="EPSG:28992")
    with pytest.raises(UrbanvoxError, match="empty.las contains no points"):
        read_point_clouds(path)


def test_no_ground_points_lists_classes(tmp_path):
    xyz, classes = town()
    classes[classes == 2] = 1
    path = write_las(tmp_path / "noground.las", xyz, classes, crs="EPSG:28992")
    with pytest.raises(UrbanvoxError) as err:
        read_point_clouds(path)
    msg = str(err.value)
    assert "GROUND_CLASSES" in msg and "[2]" in msg
    assert f"1 (unclassified): {(classes == 1).sum()}" in msg and "6 (building)" in msg


def test_geographic_crs_in_header(tmp_path):
    xyz, classes = town(x0=4.35, y0=52.0)
    path = write_las(tmp_path / "wgs84.las", xyz * (1e-4, 1e-4, 1), classes, crs="EPSG:4326")
    with pytest.raises(UrbanvoxError, match=r"wgs84.las .*geographic \(WGS 84 \(EPSG:4326\), degrees\).*reproject"):
        read_point_clouds(path)


def test_no_crs_needs_parameter(tmp_path):
    xyz, classes = town()
    path = write_las(tmp_path / "nocrs.laz", xyz, classes)
    with pytest.raises(UrbanvoxError, match=r"nocrs.laz has no CRS in its header; set the CRS parameter"):
        read_point_clouds(path)
    assert read_point_clouds(path, crs="EPSG:28992").crs.to_epsg() == 28992


def test_override_wins_over_header_with_warning(tmp_path):
    xyz, classes = town()
    path = write_las(tmp_path / "a.las", xyz, classes, crs="EPSG:2154")
    pts = read_point_clouds(path, crs="EPSG:28992")
    assert pts.crs.to_epsg() == 28992
    assert any("declares" in w and "EPSG:2154" in w for w in pts.warnings)


def test_collection_shares_crs(tmp_path):
    xyz, classes = town()
    a = write_las(tmp_path / "a.las", xyz, classes, crs="EPSG:28992")
    b = write_las(tmp_path / "b.laz", xyz + (50, 0, 0), classes, crs="EPSG:28992", version="1.2", point_format=1)
    c = write_las(tmp_path / "c.las", xyz + (100, 0, 0), classes)  # no CRS: takes the others'
    pts = read_point_clouds([a, b, c])
    assert pts.crs.to_epsg() == 28992 and pts.n_points == 3 * len(xyz)
    assert len(pts.ground) == 3 * (classes == 2).sum()
    assert any("c.las" in w and "no CRS" in w for w in pts.warnings)


def test_collection_crs_mismatch_names_both_files(tmp_path):
    xyz, classes = town()
    a = write_las(tmp_path / "first.las", xyz, classes, crs="EPSG:28992")
    b = write_las(tmp_path / "second.las", xyz, classes, crs="EPSG:2154")
    with pytest.raises(UrbanvoxError) as err:
        read_point_clouds([a, b])
    msg = str(err.value)
    assert "first.las" in msg and "second.las" in msg and "EPSG:28992" in msg and "EPSG:2154" in msg
    # The CRS parameter settles it (with warnings).
    pts = read_point_clouds([a, b], crs="EPSG:28992")
    assert pts.crs.to_epsg() == 28992 and pts.warnings


def test_bad_files(tmp_path):
    with pytest.raises(UrbanvoxError, match="does not exist"):
        read_point_clouds(tmp_path / "missing.laz", crs="EPSG:28992")
    text = tmp_path / "notlas.las"
    text.write_text("x,y,z\n1,2,3\n")
    with pytest.raises(UrbanvoxError, match="notlas.las cannot be read as a LAS/LAZ"):
        read_point_clouds(text, crs="EPSG:28992")
    with pytest.raises(UrbanvoxError, match="folder"):
        read_point_clouds(tmp_path, crs="EPSG:28992")
    with pytest.raises(UrbanvoxError, match="No point cloud file"):
        read_point_clouds([])


def test_truncated_laz(tmp_path):
    n = 100_000
    rng = np.random.default_rng(1)
    path = write_las(tmp_path / "full.laz", rng.random((n, 3)) * 100, np.full(n, 2), crs="EPSG:28992")
    cut = tmp_path / "cut.laz"
    cut.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    with pytest.raises(UrbanvoxError, match="cut.laz"):
        read_point_clouds(cut)


@pytest.mark.filterwarnings("ignore:invalid value encountered in cast:RuntimeWarning")
def test_non_finite_coordinates(tmp_path):
    header = laspy.LasHeader(version="1.2", point_format=3)
    las = laspy.LasData(header)
    las.X = las.Y = las.Z = np.arange(4)
    las.classification = np.array([2, 2, 6, 6], dtype=np.uint8)
    las.header.offsets = np.array([np.nan, 0.0, 0.0])  # a corrupt header: every x is NaN
    las.write(str(tmp_path / "nan.las"))
    with pytest.raises(UrbanvoxError, match="non-finite"):
        read_point_clouds(tmp_path / "nan.las", crs="EPSG:28992")


def test_withheld_points_dropped(tmp_path):
    xyz, classes = town()
    withheld = np.zeros(len(xyz), dtype=np.uint8)
    withheld[np.flatnonzero(classes == 2)[:5]] = 1
    pts = read_point_clouds(write_las(tmp_path / "w.las", xyz, classes, crs="EPSG:28992", withheld=withheld))
    assert len(pts.ground) == (classes == 2).sum() - 5
    assert any("withheld" in w for w in pts.warnings)


def test_all_ground_withheld_says_so(tmp_path):
    """Withheld ground points are dropped: the message says they were there, not that the class is absent."""
    xyz, classes = town()
    path = write_las(tmp_path / "w.las", xyz, classes, crs="EPSG:28992", withheld=(classes == 2).astype(np.uint8))
    with pytest.raises(UrbanvoxError, match=r"once the (\d+) points flagged 'withheld'"):
        read_point_clouds(path)


def test_a_zero_scale_in_the_header_is_refused(tmp_path):
    """A scale of zero puts every point at the offset on that axis: a corrupt
    header, refused rather than a model of one line (a 1-voxel-wide block)."""
    xyz, classes = town()
    path = write_las(tmp_path / "z.las", xyz, classes, crs="EPSG:28992")
    raw = bytearray(path.read_bytes())
    struct.pack_into("<d", raw, 131, 0.0)  # the x scale (LAS header offset 131)
    path.write_bytes(bytes(raw))
    with pytest.raises(UrbanvoxError, match="scales .* include zero"):
        read_point_clouds(path)


@pytest.mark.parametrize("version, fmt", [("1.2", 1), ("1.4", 6)])
def test_compiled_chunks_give_numpy_rows_bit_for_bit(tmp_path, monkeypatch, version, fmt):
    from core import jit

    rng = np.random.default_rng(3)
    n = 5000
    xyz = rng.random((n, 3)) * (900.0, 700.0, 40.0) + (85000.123, 447000.456, -3.2)
    classes = rng.choice([1, 2, 5, 6, 9, 17], n)
    withheld = (rng.random(n) < 0.05).astype(np.uint8)
    path = write_las(tmp_path / "r.laz", xyz, classes, crs="EPSG:28992", version=version, point_format=fmt,
                     withheld=withheld)
    monkeypatch.setattr(las_module, "CHUNK_POINTS", 777)  # chunks of every size, the last one short
    read = {}
    for name, ready in (("numpy", lambda name: False), ("compiled", lambda name: True)):
        monkeypatch.setattr(jit, "ready", ready)
        read[name] = read_point_clouds(path, "2,9", "6")
    a, b = read["numpy"], read["compiled"]
    assert a.ground.tobytes() == b.ground.tobytes() and a.building.tobytes() == b.building.tobytes()
    assert a.class_counts == b.class_counts and a.warnings == b.warnings and a.n_points == b.n_points == n
    kept = withheld == 0
    assert len(b.ground) == (np.isin(classes, [2, 9]) & kept).sum() > 0
    assert len(b.building) == ((classes == 6) & kept).sum() > 0
    np.testing.assert_allclose(b.building, xyz[(classes == 6) & kept], atol=1e-3)


def test_chunked_reading_and_cancel(tmp_path, monkeypatch):
    xyz, classes = town(n=1000)
    path = write_las(tmp_path / "a.laz", xyz, classes, crs="EPSG:28992")
    whole = read_point_clouds(path)
    monkeypatch.setattr(las_module, "CHUNK_POINTS", 97)
    calls = []
    chunked = read_point_clouds(path, is_cancelled=lambda: calls.append(1) or False)
    assert len(calls) >= 1000 // 97  # checked between chunks
    np.testing.assert_array_equal(chunked.ground, whole.ground)
    np.testing.assert_array_equal(chunked.building, whole.building)
    late = []  # cancel at the third check: in the middle of the file
    with pytest.raises(Cancelled):
        read_point_clouds(path, is_cancelled=lambda: late.append(1) or len(late) >= 3)
    assert len(late) == 3


# ----------------------------------------------------------------------------- real LAS/LAZ files


def test_real_delft_ahn3_without_crs(shared_data):
    path = data_file(shared_data, "delft_ahn3/ahn3_cropped_2.laz")
    with pytest.raises(UrbanvoxError, match="no CRS"):
        read_point_clouds(path)
    pts = read_point_clouds(path, crs="EPSG:28992")
    assert pts.class_counts == {1: 86308, 2: 87130, 6: 33312, 9: 568, 26: 1114}
    assert pts.n_points == 208432 and len(pts.ground) == 87130 and len(pts.building) == 33312
    assert any("1114 points of class 26" in w for w in pts.warnings)
    assert 85000 <= pts.ground[:, 0].min() and pts.ground[:, 0].max() <= 85073


def test_real_montpellier_tile_collection(shared_data):
    paths = sorted(glob.glob(str(data_file(shared_data, "montpellier_ign") / "*.laz")))
    assert len(paths) == 6
    start = time.perf_counter()
    pts = read_point_clouds(paths)
    print(f"\nmontpellier 6 tiles: {pts.n_points} pts in {time.perf_counter() - start:.2f} s, {pts.class_counts}")
    assert pts.crs.to_epsg() == 2154
    assert pts.class_counts[64] == 210 and len(pts.ground) == pts.class_counts[2]
    assert len(pts.building) == pts.class_counts[6]
    assert any("class 64" in w for w in pts.warnings)


def test_real_ign_lidarprod(shared_data):
    pts = read_point_clouds(data_file(shared_data, "ign_lidarprod/870000_6618000.subset.postValidation.laz"))
    assert pts.crs.to_epsg() == 2154
    assert {208, 214} <= set(pts.class_counts) and len(pts.building) == pts.class_counts[6]
    st_barth = data_file(shared_data, "ign_lidarprod/St_Barth_RGAF09_UTM20N_IGN_1988_SB_subset_100m.laz")
    with pytest.raises(UrbanvoxError, match="no CRS"):
        read_point_clouds(st_barth)
    pts = read_point_clouds(st_barth, crs="EPSG:5490")
    assert len(pts.ground) == 30825 and len(pts.building) == 54277


def test_real_pdal_sample(shared_data):
    path = data_file(shared_data, "pdal/sample_c.las")
    pts = read_point_clouds(path, crs="EPSG:2154")  # CRS unknown: any projected CRS to read it
    assert len(pts.ground) == 1368 and len(pts.building) == 12525
    assert pts.class_counts[31] == 339


# ----------------------------------------------------------------------------- meshes


def box(extents=(10.0, 10.0, 6.0), base=(0.0, 0.0, 0.0)):
    mesh = trimesh.creation.box(extents=extents)
    mesh.apply_translation(np.asarray(base) + (0, 0, extents[2] / 2))
    return mesh


@pytest.mark.parametrize("suffix", MESH_SUFFIXES)
def test_read_formats(tmp_path, suffix):
    path = tmp_path / f"house{suffix}"
    box(base=(2_600_000.0, 1_200_000.0, 400.0)).export(str(path))
    tris = read_triangles(path)
    assert tris.vertices.shape == (8, 3) and tris.faces.shape == (12, 3) and tris.n_dropped == 0
    assert tris.corners().shape == (12, 3, 3) and tris.faces.dtype == np.int64
    assert edge_counts(tris) == (0, 0)
    # float32 STL at projected coordinates: precision warning
    assert any("float32" in w for w in tris.warnings) == (suffix == ".stl")


def test_soup_merged_and_degenerates_dropped(tmp_path):
    corners = box().triangles  # (12, 3, 3) soup
    extra = np.array([[[0, 0, 0], [1, 1, 1], [2, 2, 2]], [[0, 0, 0], [0, 0, 0], [5, 0, 0]]], dtype=float)
    soup = np.concatenate([corners, extra, corners[:1]])  # collinear, repeated corner, duplicate
    path = tmp_path / "soup.stl"
    trimesh.Trimesh(**trimesh.triangles.to_kwargs(soup), process=False).export(str(path))
    tris = read_triangles(path)
    assert tris.faces.shape == (12, 3) and tris.vertices.shape == (8, 3)
    assert tris.n_dropped == 2
    assert any("degenerate" in w for w in tris.warnings) and any("duplicated" in w for w in tris.warnings)


def test_nan_vertices_dropped(tmp_path):
    path = tmp_path / "nan.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv nan 0 0\nf 1 2 3\nf 1 2 4\n")
    tris = read_triangles(path)
    assert tris.faces.shape == (1, 3) and tris.n_dropped == 1
    assert any("non-finite" in w for w in tris.warnings)


def test_multi_object_file_concatenated(tmp_path):
    path = tmp_path / "two.obj"
    path.write_text(
        "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no b\nv 0 0 5\nv 1 0 5\nv 0 1 5\nf 4 5 6\n"
    )
    tris = read_triangles(path)
    assert tris.faces.shape == (2, 3) and sorted(set(tris.vertices[:, 2])) == [0.0, 5.0]


def test_bad_meshes(tmp_path):
    with pytest.raises(UrbanvoxError, match="not supported"):
        read_triangles(tmp_path / "city.gml")
    with pytest.raises(UrbanvoxError, match="does not exist"):
        read_triangles(tmp_path / "missing.stl")
    (tmp_path / "empty.stl").write_bytes(b"")
    with pytest.raises(UrbanvoxError, match="empty.stl"):
        read_triangles(tmp_path / "empty.stl")
    (tmp_path / "garbage.ply").write_text("this is not a mesh\n")
    with pytest.raises(UrbanvoxError, match="garbage.ply"):
        read_triangles(tmp_path / "garbage.ply")
    flat = tmp_path / "flat.obj"
    flat.write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
    with pytest.raises(UrbanvoxError, match="degenerate"):
        read_triangles(flat)
    with pytest.raises(Cancelled):
        box().export(str(tmp_path / "b.stl"))
        read_triangles(tmp_path / "b.stl", is_cancelled=lambda: True)


def as_triangles(*meshes):
    mesh = trimesh.util.concatenate(list(meshes))
    return Triangles(np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64))


def test_base_points_drop_floating_roof_parts():
    house = box((10, 10, 8), (0, 0, 100))
    dormer = box((2, 2, 2), (0, 0, 108))  # a separate part on the roof
    neighbour = box((8, 8, 6), (20, 0, 102))  # 2 m higher terrain, 20 m away: kept
    uphill = box((8, 8, 6), (0, 60, 108))  # 60 m away, 8 m higher (13 % slope): kept
    pts = base_points(as_triangles(house, dormer, neighbour, uphill), voxel_size=1.0)
    assert set(np.round(pts[:, 2], 6)) == {100.0, 102.0, 108.0}
    assert not np.any((np.abs(pts[:, 0]) < 1.01) & (np.abs(pts[:, 1]) < 1.01) & (pts[:, 2] > 100))


def test_base_points_densify_footprint():
    voxel = 1.0
    pts = base_points(as_triangles(box((10, 6, 5))), voxel_size=voxel)
    assert np.all(pts[:, 2] == 0.0)
    # Points along the footprint outline are at most voxel / 2 apart.
    outline = pts[(np.abs(np.abs(pts[:, 0]) - 5) < 1e-9) | (np.abs(np.abs(pts[:, 1]) - 3) < 1e-9)]
    perimeter = 2 * (10 + 6)
    assert len(outline) >= perimeter / (voxel / 2)
    from scipy.spatial import cKDTree

    gap = cKDTree(outline).query(outline, k=2)[0][:, 1].max()
    assert gap <= voxel / 2 + 1e-9
    # Tolerance band: vertices less than 0.25 voxel above the lowest are wall bottoms too.
    assert len(base_points(as_triangles(box((10, 6, 0.2))), voxel_size=1.0)) > 8


def test_base_points_units_and_validation():
    feet = base_points(as_triangles(box((30, 30, 20))), voxel_size=3.0, unit=0.3048)
    assert np.all(feet[:, 2] == 0.0)
    with pytest.raises(UrbanvoxError):
        base_points(as_triangles(box()), voxel_size=0.0)


def test_real_zurich_stl(shared_data):
    path = data_file(shared_data, "cityjson/zurich_subset_lod2_buildings.stl")
    start = time.perf_counter()
    tris = read_triangles(path)
    read_s = time.perf_counter() - start
    n_open, n_nonmanifold = edge_counts(tris)
    start = time.perf_counter()
    ground = base_points(tris, voxel_size=1.0)
    base_s = time.perf_counter() - start
    print(
        f"\nzurich: {len(tris.vertices)} vertices, {len(tris.faces)} faces, {tris.n_dropped} dropped, "
        f"{n_open} open edges, {n_nonmanifold} non-manifold edges, read {read_s:.2f} s; "
        f"base_points(1 m): {len(ground)} pts, z {ground[:, 2].min():.2f}..{ground[:, 2].max():.2f} "
        f"in {base_s:.2f} s"
    )
    assert tris.faces.shape[0] > 4500 and tris.n_dropped < 0.05 * 5142
    assert n_open > 0 and n_nonmanifold > 0  # real CityGML exports are not closed
    assert any("float32" in w for w in tris.warnings)
    z = tris.vertices[:, 2]
    assert z.min() <= ground[:, 2].min() and ground[:, 2].max() < z.max()
    # Every base point lies near the bottom of the mesh around it: no roof level z.
    from scipy.spatial import cKDTree

    tree = cKDTree(tris.vertices[:, :2])
    near = tree.query_ball_point(ground[::50, :2], r=15.0)
    local_low = np.array([z[i].min() for i in near])
    assert np.all(ground[::50, 2] - local_low <= 3.0 + 0.15 * 30)


def test_rows_are_written_in_place_grown_past_the_count_and_trimmed():
    """The reader's table of points (core.readers.las._Rows): chunks written in
    turn, non-finite rows of the last chunk dropped, more rows than the headers
    counted, and the table trimmed to the rows written."""
    from core.readers.las import _Rows

    rows = _Rows(4)
    rows.next(3)[:] = [[0, 0, 0], [1, 1, 1], [2, 2, 2]]
    part = rows.next(3)
    part[:] = [[3, 3, 3], [np.nan, 0, 0], [5, 5, 5]]
    rows.keep_last(np.isfinite(part).all(axis=1))
    rows.next(1)[:] = [[6, 6, 6]]
    table = rows.result()
    assert table.shape == (6, 3) and table.flags.owndata
    assert table[:, 0].tolist() == [0, 1, 2, 3, 5, 6]
    assert _Rows(10).result().shape == (0, 3)


@pytest.mark.parametrize("kind", ["float", "int"])
def test_sorted_rows_give_what_numpy_unique_gives(kind):
    """The mesh reader merges vertices and finds repeated triangles with core.topology.sorted_rows
    (a lexsort): the same unique rows, first occurrences and inverse as np.unique(axis=0)."""
    from core.topology import sorted_rows, unique_rows

    rng = np.random.default_rng(7)
    if kind == "float":
        rows = np.round(rng.normal(0, 3, (4000, 3)), 0) + 0.0  # many repeats, negatives, zeros
    else:
        rows = np.sort(rng.integers(0, 15, (4000, 3)), axis=1)
    unique, first, inverse = np.unique(rows, axis=0, return_index=True, return_inverse=True)
    order, starts = sorted_rows(rows)
    assert np.array_equal(rows[order[starts]], unique)
    assert np.array_equal(order[starts], first)
    mine = np.empty(len(rows), dtype=np.int64)
    mine[order] = np.cumsum(starts) - 1
    assert np.array_equal(mine, inverse.reshape(-1))
    rows_of, inverse_of = unique_rows(rows)
    assert np.array_equal(rows_of, unique) and np.array_equal(inverse_of, inverse.reshape(-1))
    assert len(unique) < len(rows)


def test_progress_goes_over_the_points_of_every_file(tmp_path, monkeypatch):
    """A tile collection's reading moves the bar chunk by chunk, over all its files' points."""
    xyz, classes = town(n=3000)
    paths = [write_las(tmp_path / f"t{i}.laz", xyz + (100.0 * i, 0.0, 0.0), classes, crs="EPSG:28992")
             for i in range(2)]
    monkeypatch.setattr(las_module, "CHUNK_POINTS", 1000)
    seen = []
    read_point_clouds(paths, progress=lambda f, m: seen.append((f, m)))
    assert [f for f, _ in seen] == pytest.approx([k / 6 for k in range(1, 7)])
    assert {m for _, m in seen} == {"Reading point cloud"}
