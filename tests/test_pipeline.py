"""The whole method on the synthetic district, against its analytic truth.

Runs the point-cloud and the mesh reconstructions at 1 m and 0.5 m voxels
once per session and checks blocks, volumes, topology, conformity, quality,
distances and normals against :mod:`core.synthetic`'s truth.
"""
import numpy as np
import pyproj
import pytest
import shapely
from scipy.spatial import cKDTree

from core.errors import Cancelled, UrbanvoxError
from core.pipeline import (MESH_READ_SHARE, MESH_SAMPLE_SHARE, READ_SHARE, STEP_STARTS, ReconstructionParams,
                           reconstruct_mesh, reconstruct_point_cloud)
from core.quality import quad_quality
from core.readers.mesh import read_triangles
from core.sampling import sample_triangles
from core.surface import AIR_REGION, GROUND_REGION
from core.topology import check_surface, signed_volume

RUNS = [("las", 1.0), ("las", 0.5), ("stl", 1.0), ("stl", 0.5)]


@pytest.fixture(scope="session")
def runs(district):
    """Reconstructions keyed by (input kind, voxel size)."""
    cache = {}

    def get(kind, h):
        if (kind, h) not in cache:
            params = ReconstructionParams(voxel_size=h, extent=district.district.extent)
            if kind == "las":
                cache[kind, h] = reconstruct_point_cloud(district.laz, params=params)
            else:
                cache[kind, h] = reconstruct_mesh(district.stl, crs=district.crs,
                                                  ground_path=district.ground_stl, params=params)
        return cache[kind, h]
    return get


def matched(result, district):
    """(truth block, result row, block id) for every expected truth block."""
    rows = result.block_rows()
    footprints = [shapely.from_wkb(w) for w in result.footprint_wkb()]
    pairs = []
    for truth in district.expected_blocks:
        polygon = shapely.from_wkt(truth.footprint_wkt)
        hits = [i for i, f in enumerate(footprints) if f.intersection(polygon).area > 0.5 * polygon.area]
        assert len(hits) == 1, f"{truth.name}: {len(hits)} reconstructed blocks cover it"
        pairs.append((truth, rows[hits[0]], int(result.blocks.block_id[hits[0]])))
    return pairs


@pytest.mark.parametrize("kind,h", RUNS)
def test_block_count_and_volumes_match_the_truth(runs, district, kind, h):
    result = runs(kind, h)
    assert len(result.blocks) == len(district.expected_blocks)
    pairs = matched(result, district)
    assert len({block for _, _, block in pairs}) == len(pairs)  # one truth block each
    mesh_errors = []
    for truth, row, _ in pairs:
        # Voxel model: every voxel the true surface cuts may fall either side,
        # so the error is at most one voxel layer over the surface.
        assert abs(row["volume"] - truth.volume) <= truth.surface_area * h, truth.name
        assert row["footprint_area"] == pytest.approx(truth.footprint_area, abs=truth.footprint_area ** 0.5 * 4 * h)
        assert row["height"] == pytest.approx(truth.height, abs=1.5 * h)
        mesh_errors.append(abs(row["mesh_volume"] - truth.volume) / truth.volume)
    # Smoothed and projected onto the data, volumes come within a few percent.
    assert max(mesh_errors) < 0.03
    assert np.mean(mesh_errors) < 0.01


def test_blocks_below_the_thresholds_are_dropped(runs, district):
    result = runs("las", 1.0)
    footprints = [shapely.from_wkb(w) for w in result.footprint_wkb()]
    small = [b for b in district.blocks if b.below_thresholds]
    assert len(small) >= 3
    for truth in small:
        polygon = shapely.from_wkt(truth.footprint_wkt)
        assert not any(f.intersects(polygon) for f in footprints), truth.name
    assert any("Dropped" in w for w in result.warnings)


@pytest.mark.parametrize("kind,h", RUNS)
def test_every_region_is_closed_manifold_outward_and_conforming(runs, kind, h):
    result = runs(kind, h)
    mesh = result.mesh.triangulated()  # moved quads are not planar: as exported
    # Conforming by construction: one face between two different regions, never twice.
    assert (mesh.regions[:, 0] != mesh.regions[:, 1]).all()
    assert len(np.unique(np.sort(mesh.quads, axis=1), axis=0)) == len(mesh.quads)
    assert check_surface(result.mesh.closed_surface(AIR_REGION)).ok  # quads too
    regions = [int(b) for b in result.blocks.block_id] + [GROUND_REGION, AIR_REGION]
    total = 0.0
    for region in regions:
        quads = mesh.closed_surface(region)
        report = check_surface(quads)
        assert report.ok, (region, report)
        volume = signed_volume(mesh.nodes, quads)
        assert volume > 0, region
        total += volume
    # The regions tile the domain box exactly: nothing overlaps, nothing is missing.
    domain = np.prod(np.asarray(result.grid.shape) * result.grid.voxel_size)
    assert total == pytest.approx(domain, rel=1e-9)


@pytest.mark.parametrize("kind,h", RUNS)
def test_no_face_below_the_quality_threshold(runs, kind, h):
    result = runs(kind, h)
    quality = quad_quality(result.mesh.nodes, result.mesh.quads)
    assert quality.min() >= ReconstructionParams().quality_threshold
    assert min(row["min_quality"] for row in result.block_rows()) >= 0.2


@pytest.fixture(scope="session")
def truth_surface(district):
    """Dense samples of the true building surfaces (the district's STL)."""
    corners = read_triangles(district.stl).corners()
    return cKDTree(sample_triangles(corners, 0.05))


@pytest.mark.parametrize("kind,h", RUNS)
def test_smoothing_and_projection_bring_nodes_closer_to_the_true_surface(runs, district, truth_surface,
                                                                         kind, h):
    result = runs(kind, h)
    quads, _ = result.mesh.block_faces()
    nodes = np.unique(quads)
    xmax = district.district.extent[2]
    voxel = result.grid.to_world(result.surface.nodes[nodes])
    final = result.grid.to_world(result.mesh.nodes[nodes])
    inside = voxel[:, 0] < xmax - 2 * h  # the truth's border cut face is not in the STL
    before = truth_surface.query(voxel[inside])[0].mean()
    after = truth_surface.query(final[inside])[0].mean()
    print(f"{kind} {h} m: mean node distance to the true surface {before:.3f} -> {after:.3f} m")
    assert after < before


@pytest.mark.parametrize("kind,h", RUNS)
def test_rotated_building_facade_normals(runs, district, kind, h):
    """Paper figure 5: walls at 45 degrees to the grid come out at 45 degrees."""
    result = runs(kind, h)
    block = next(b for t, _, b in matched(result, district) if t.name == "rotated45")
    triangles = result.mesh.triangulated().closed_surface(block)
    p = result.mesh.nodes[triangles]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    area = np.linalg.norm(normal, axis=1) / 2
    normal /= 2 * area[:, None]
    facade = np.abs(normal[:, 2]) < 0.5
    # True wall normals point at 45 + 90 k degrees.
    deviation = np.abs(np.degrees(np.arctan2(normal[facade, 1], normal[facade, 0])) % 90 - 45)
    weights = area[facade]
    order = np.argsort(deviation)
    median = deviation[order][np.searchsorted(np.cumsum(weights[order]) / weights.sum(), 0.5)]
    mean = float((deviation * weights).sum() / weights.sum())
    print(f"{kind} {h} m: rotated45 facade normals off by {median:.1f} (median), {mean:.1f} (mean) degrees")
    assert median <= 10.0
    if kind == "stl":  # facades are in the data: projection straightens them everywhere
        assert mean <= 10.0


def test_voxel_faces_on_the_rotated_building_are_all_off_by_45_degrees(runs, district):
    """The reference the smoothing improves on: voxel faces are axis-aligned."""
    result = runs("stl", 1.0)
    block = next(b for t, _, b in matched(result, district) if t.name == "rotated45")
    quads = result.surface.closed_surface(block)
    p = result.surface.nodes[quads]
    normal = np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1])
    horizontal = np.abs(normal[:, 2]) < 1e-9
    angles = np.degrees(np.arctan2(normal[horizontal, 1], normal[horizontal, 0])) % 90
    assert np.allclose(angles, 0.0)


def test_memory_guard_stops_before_allocating(district):
    params = ReconstructionParams(voxel_size=0.05, max_memory=64 * 2**20)
    with pytest.raises(UrbanvoxError, match="voxel size of at least"):
        reconstruct_point_cloud(district.laz, params=params)


def test_cancel_stops_the_run(district):
    calls = []

    def cancelled():
        calls.append(1)
        return len(calls) > 3

    with pytest.raises(Cancelled):
        reconstruct_point_cloud(district.laz, params=ReconstructionParams(voxel_size=2.0),
                                is_cancelled=cancelled)


def test_progress_is_reported_through_every_stage(district):
    seen = []
    reconstruct_point_cloud(district.laz, params=ReconstructionParams(voxel_size=2.0),
                            progress=lambda f, m: seen.append((f, m)))
    fractions = [f for f, _ in seen]
    assert fractions == sorted(fractions) and fractions[0] == 0.0 and fractions[-1] == 1.0
    at = {m: f for f, m in reversed(seen)}  # where each message is first shown
    # The reading has its share, then every step starts where its share of a run's time puts it.
    reading = [f for f, m in seen if m == "Reading point cloud"]
    assert reading[0] == 0.0 and reading[-1] == pytest.approx(READ_SHARE)
    for message, step in (("Ground level of every column", "ground"), ("Measuring the blocks", "measure"),
                          ("Projecting nodes onto the data", "project_blocks")):
        assert at[message] == pytest.approx(READ_SHARE + (1 - READ_SHARE) * STEP_STARTS[step])
    # The long steps move the bar as they go: the smoothing pass by pass, the projection part by part.
    assert [m for _, m in seen if m.startswith("Smoothing: ")] == [f"Smoothing: pass {k} of 3" for k in (1, 2, 3)]
    parts = ["nodal normals", "nearest data points", "moving-least-squares planes", "quality control",
             "face crossings"]
    blocks = [m for _, m in seen if m.startswith("Projecting block nodes: ")]
    assert sorted(set(blocks), key=blocks.index) == [f"Projecting block nodes: {p}" for p in parts]
    ground = [m for _, m in seen if m.startswith("Projecting ground nodes: ")]
    assert sorted(set(ground), key=ground.index) == [f"Projecting ground nodes: {p}" for p in parts[:4]]
    projection = [f for f, m in seen if m.startswith("Projecting")]
    assert len(set(projection)) >= 7
    # The elimination moves the bar within its step: passes, then the repair and the blocks.
    elimination = [f for f, m in seen if m == "Eliminating unsupported boundary voxels"]
    start, end = (READ_SHARE + (1 - READ_SHARE) * STEP_STARTS[step] for step in ("eliminate", "surface"))
    assert elimination[0] == pytest.approx(start) and len(set(elimination)) >= 4
    assert elimination[-1] == pytest.approx(start + 0.85 * (end - start))
    # So do the surfaces: the regions, then the faces found, then their nodes numbered.
    surfaces = sorted(set(f for f, m in seen if m == "Conforming surfaces"))
    start, end = (READ_SHARE + (1 - READ_SHARE) * STEP_STARTS[step] for step in ("surface", "smooth"))
    assert surfaces == pytest.approx([start + share * (end - start) for share in (0.0, 0.15, 0.15 + 0.85 * 0.75)])


def test_projection_and_measures_move_the_bar_block_by_block_with_the_same_model(district, monkeypatch):
    """The nodes' nearest data points, the MLS planes and the measures' distances
    report as their blocks of rows end (small blocks here, so that the district
    has many): the bar moves within each part, never back, and the model is the
    one of a run with the usual blocks, to the last bit."""
    import core.mls
    import core.neighbours
    import core.project
    from core import jit

    params = ReconstructionParams(voxel_size=1.0)
    usual = reconstruct_point_cloud(district.laz, params=params)
    monkeypatch.setattr(core.mls, "FIT_ROWS", 64)
    monkeypatch.setattr(core.project, "_QUERY_ROWS", 64)
    monkeypatch.setattr(core.neighbours, "DISTANCE_PART_ROWS", 64)
    kernel = jit.kernels("projection_kernel")
    if kernel is not None:
        monkeypatch.setattr(kernel, "_BLOCK", 64)
    seen = []
    small = reconstruct_point_cloud(district.laz, params=params, progress=lambda f, m: seen.append((f, m)))
    fractions = [f for f, _ in seen]
    assert fractions == sorted(fractions)
    for message in ("Projecting block nodes: nearest data points",
                    "Projecting block nodes: moving-least-squares planes",
                    "Projecting ground nodes: nearest data points",
                    "Projecting ground nodes: moving-least-squares planes", "Measuring the blocks"):
        assert len({f for f, m in seen if m == message}) >= 5, message
    assert np.array_equal(small.mesh.nodes, usual.mesh.nodes)
    assert small.block_rows() == usual.block_rows()


def test_a_mesh_run_reports_its_reading_and_sampling_first(district):
    """A mesh's run: reading, then sampling (buildings, then the ground mesh), then the method's steps."""
    seen = []
    reconstruct_mesh(district.stl, crs=district.crs, ground_path=district.ground_stl,
                     params=ReconstructionParams(voxel_size=2.0), progress=lambda f, m: seen.append((f, m)))
    fractions = [f for f, _ in seen]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    sampling = [f for f, m in seen if m == "Sampling triangles"]
    assert len(sampling) >= 3 and sampling[0] == MESH_READ_SHARE and sampling[-1] == pytest.approx(MESH_SAMPLE_SHARE)
    assert next(f for f, m in seen if m == "Ground level of every column") \
        == pytest.approx(MESH_SAMPLE_SHARE + (1 - MESH_SAMPLE_SHARE) * STEP_STARTS["ground"])


def test_overwrite_points_moves_the_input_in_place_and_changes_no_result(district):
    """reconstruct_point_cloud lets the run move the points it read instead of
    copying them: the same model, and the caller's arrays are moved only then."""
    from core.pipeline import reconstruct_points
    from core.readers.las import read_point_clouds

    points = read_point_clouds([district.laz])
    params = ReconstructionParams(voxel_size=2.0)
    ground, building = points.ground.copy(), points.building.copy()
    kept = reconstruct_points(ground, building, points.crs, params, airborne=True)
    assert np.array_equal(ground, points.ground) and np.array_equal(building, points.building)
    moved = reconstruct_points(ground, building, points.crs, params, airborne=True, overwrite_points=True)
    assert np.array_equal(moved.mesh.nodes, kept.mesh.nodes)
    assert np.array_equal(moved.mesh.quads, kept.mesh.quads)
    assert moved.block_rows() == kept.block_rows()
    assert np.array_equal(ground, points.ground - moved.grid.offset)
    assert np.array_equal(building, points.building - moved.grid.offset)


def test_non_finite_points_are_dropped_with_a_warning():
    from core.inputs import _finite

    points = np.arange(30.0).reshape(10, 3)
    warnings: list[str] = []
    assert np.array_equal(_finite(points, "ground", warnings), points) and warnings == []
    points[2, 1], points[7, 0], points[8, 2] = np.nan, np.inf, -np.inf
    kept = _finite(points, "ground", warnings)
    assert np.array_equal(kept, points[[0, 1, 3, 4, 5, 6, 9]])
    assert warnings == ["Ignored 3 ground points with non-finite coordinates."]
    huge = np.full((4, 3), 1e308)  # a sum that overflows: every number is still finite
    assert len(_finite(huge, "ground", warnings)) == 4 and len(warnings) == 1


def test_an_extent_without_ground_says_where_the_data_are(district):
    """An extent beside the data, or under a roof, is named with the data's
    own extent, not blamed on the ground classes."""
    from core.pipeline import reconstruct_points
    from core.readers.las import read_point_clouds

    points = read_point_clouds([district.laz])
    x0, y0 = points.ground[:, :2].min(axis=0)
    with pytest.raises(UrbanvoxError, match=r"No ground point lies inside the extent .* misses them") as error:
        reconstruct_points(points.ground, points.building, points.crs,
                           ReconstructionParams(voxel_size=2.0, extent=(0.0, 0.0, 10.0, 10.0)), airborne=True)
    assert f"{x0:.2f}" in str(error.value) and "GROUND_CLASSES" not in str(error.value)
    roof = points.building[np.argmax(points.building[:, 2])]  # a point of the highest roof, well inside its block
    with pytest.raises(UrbanvoxError, match="under a roof"):
        reconstruct_points(points.ground, points.building, points.crs,
                           ReconstructionParams(voxel_size=2.0, extent=(roof[0] - 0.2, roof[1] - 0.2,
                                                                        roof[0] + 0.2, roof[1] + 0.2)),
                           airborne=True)


@pytest.mark.parametrize("values, says", [
    ({"voxel_size": "1"}, "voxel_size must be a number"),
    ({"support": float("nan")}, "support must be a number of 0 or more"),
    ({"min_height": -1.0}, "min_height must be a number of 0 or more"),
    ({"smoothing_iterations": -1}, "smoothing passes must be a whole number"),
    ({"smoothing_iterations": 1.5}, "smoothing passes must be a whole number"),
    ({"quality_threshold": 1.0}, "minimum face quality"),
    ({"max_projection_angle": 0.0}, "largest projection angle"),
])
def test_parameters_out_of_range_are_refused_when_made(values, says):
    with pytest.raises(UrbanvoxError, match=says):
        ReconstructionParams(**values)
    ReconstructionParams(smoothing_iterations=np.int64(2), support=np.float32(0.6))  # numpy numbers are numbers


def test_a_stray_ground_point_far_away_is_left_out_silently(district):
    """One ground point 600 km away (a corrupt record): a cluster of its own with
    no building, left out; the model is the district's, and no "1 separate
    clusters" is said."""
    from core.pipeline import reconstruct_points
    from core.readers.las import read_point_clouds

    points = read_point_clouds([district.laz])
    params = ReconstructionParams(voxel_size=2.0)
    plain = reconstruct_points(points.ground.copy(), points.building.copy(), points.crs, params, airborne=True)
    stray = np.concatenate([points.ground, points.ground[:1] + [6e5, 0, 0]])
    result = reconstruct_points(stray, points.building.copy(), points.crs, params, airborne=True)
    assert result.block_rows() == plain.block_rows()
    assert not any("separate clusters" in str(w) for w in result.warnings)


def test_point_arrays_of_another_shape_are_refused():
    """(N, 2) or (N, 4) arrays are no (x, y, z) rows: refused, not reshaped into scrambled points."""
    from core.pipeline import reconstruct_points

    good = np.zeros((10, 3))
    for bad in (np.zeros((12, 2)), np.zeros((12, 4))):
        with pytest.raises(UrbanvoxError, match=r"\(x, y, z\) rows, got shape"):
            reconstruct_points(bad, good, pyproj.CRS("EPSG:28992"), ReconstructionParams(voxel_size=1.0), airborne=True)


def test_clusters_move_the_progress_bar_by_their_points(district):
    """Two clusters far apart, one with a quarter of the other's points: the first ends at its share
    of the two's points (a patch of ground far from both, a cluster left out, is not counted)."""
    from core.pipeline import reconstruct_points
    from core.readers.las import read_point_clouds

    points = read_point_clouds([district.laz])
    far = np.array([3000.0, 0.0, 0.0])
    ground = np.concatenate([points.ground, points.ground[::4] + far, points.ground[::9] + 2 * far])
    building = np.concatenate([points.building, points.building[::4] + far])
    seen = []
    result = reconstruct_points(ground, building, points.crs, ReconstructionParams(voxel_size=2.0), airborne=True,
                                progress=lambda f, m: seen.append((f, m)))
    assert result.stats["clusters"] == 2
    fractions = [f for f, _ in seen]
    assert fractions == sorted(fractions) and fractions[-1] == pytest.approx(1.0)
    first = len(points.ground) + len(points.building)
    end_of_first = [f for f, m in seen if m.startswith("Cluster 1/2: ")][-1]
    second = (len(points.ground) + 3) // 4 + (len(points.building) + 3) // 4
    assert end_of_first == pytest.approx(first / (first + second))
