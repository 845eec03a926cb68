"""Every file of ../shared/data through the whole method: closed, manifold,
conforming, quality-controlled (skipped when the folder is absent)."""
import numpy as np
import pytest

from core.pipeline import ReconstructionParams, reconstruct_mesh, reconstruct_point_cloud
from core.quality import quad_quality
from core.surface import AIR_REGION, GROUND_REGION
from core.topology import check_surface

pytestmark = pytest.mark.slow

POINT_CLOUDS = {
    "delft": ("delft_ahn3/ahn3_cropped_2.laz", "EPSG:28992"),
    "st_barth": ("ign_lidarprod/St_Barth_RGAF09_UTM20N_IGN_1988_SB_subset_100m.laz", "EPSG:5490"),
    "sample_c": ("pdal/sample_c.las", "EPSG:32610"),
    "jura": ("ign_lidarprod/870000_6618000.subset.postValidation.laz", None),
}


def check_model(result):
    mesh = result.mesh
    assert (mesh.regions[:, 0] != mesh.regions[:, 1]).all()
    for region in [int(b) for b in result.blocks.block_id] + [GROUND_REGION, AIR_REGION]:
        report = check_surface(mesh.triangulated().closed_surface(region))
        assert report.ok, (region, report)
    assert quad_quality(mesh.nodes, mesh.quads).min() >= ReconstructionParams().quality_threshold
    rows = result.block_rows()
    assert all(r["mesh_volume"] > 0 and np.isfinite(r["mean_dist"]) for r in rows)


@pytest.mark.parametrize("name", POINT_CLOUDS)
def test_point_cloud_files(shared_data, name):
    relative, crs = POINT_CLOUDS[name]
    result = reconstruct_point_cloud(shared_data / relative, crs=crs, params=ReconstructionParams(voxel_size=1.0))
    assert len(result.blocks) > 0
    check_model(result)


def test_voxels_too_small_for_the_points_are_said_with_a_size_that_fits(shared_data):
    """Delft's AHN3 file has about one building point per roof voxel at 0.5 m:
    no warning there; at 0.35 m most roof voxels see none, and the warning
    suggests a size near the 0.7 m where two points fall in each."""
    path = shared_data / POINT_CLOUDS["delft"][0]
    if not path.exists():
        pytest.skip("real test data not available")
    sparse = [w for w in reconstruct_point_cloud(path, crs="EPSG:28992", params=ReconstructionParams(voxel_size=0.5))
              .warnings if "sparse" in w]
    assert sparse == []
    said = [w for w in reconstruct_point_cloud(path, crs="EPSG:28992", params=ReconstructionParams(voxel_size=0.35))
            .warnings if "sparse" in w]
    assert len(said) == 1 and "voxels of 0.35 m" in said[0]
    suggested = float(said[0].split("Voxels of at least ")[1].split(" m")[0])
    assert 0.6 <= suggested <= 0.8


def test_montpellier_tiles_read_as_one_collection(shared_data):
    tiles = sorted((shared_data / "montpellier_ign").glob("*.laz"))
    assert len(tiles) == 6
    result = reconstruct_point_cloud(tiles, params=ReconstructionParams(voxel_size=1.0))
    # Checked on the picture: a row of terraced houses, two tall L-shaped blocks, houses around.
    assert 8 <= len(result.blocks) <= 12
    assert 30e3 <= result.summary["total_volume"] <= 50e3
    check_model(result)


def test_zurich_stl_scattered_over_kilometres(shared_data):
    result = reconstruct_mesh(shared_data / "cityjson/zurich_subset_lod2_buildings.stl", crs="EPSG:2056",
                              params=ReconstructionParams(voxel_size=1.0))
    assert result.stats["clusters"] >= 40       # one grid per group of buildings
    assert 46 <= len(result.blocks) <= 52        # 49 buildings in the source CityJSON
    check_model(result)


GAP_FILL_CASES = {  # file, CRS, voxel size
    "delft_05": ("delft_ahn3/ahn3_cropped_2.laz", "EPSG:28992", 0.5),
    "montpellier_1": ("montpellier_ign", None, 1.0),
    "jura_05": ("ign_lidarprod/870000_6618000.subset.postValidation.laz", None, 0.5),
}


@pytest.mark.parametrize("name", GAP_FILL_CASES)
def test_ground_under_roofs_is_guessed_as_well_as_by_a_triangulation(shared_data, name):
    """The file's own roof gaps, laid over its observed ground elsewhere (six
    shifts): the filled levels against the observed ones, and against linear
    interpolation over a Delaunay triangulation of the gaps' rims (this
    module's method before the chords, as LinearNDInterpolator)."""
    from scipy import ndimage
    from scipy.interpolate import LinearNDInterpolator

    from core.ground import _fill_missing, column_ground_level
    from core.grid import GridWindow
    from core.readers.las import read_point_clouds

    relative, crs, h = GAP_FILL_CASES[name]
    path = shared_data / relative
    points = read_point_clouds(sorted(path.glob("*.laz")) if path.is_dir() else path, crs=crs)
    window = GridWindow.around(points.ground, points.building, h)
    grid = window.grid(h)
    level = column_ground_level(grid, points.ground - grid.offset)
    roofs = ~level.observed
    nx, ny = roofs.shape
    xs, ys = grid.column_centres()
    chords, triangles = [], []
    for shift in [(nx // 3, 0), (0, ny // 3), (nx // 2, ny // 2), (-nx // 4, ny // 5), (nx // 5, -ny // 4),
                  (2 * nx // 3, 2 * ny // 3)]:
        laid = np.roll(roofs, shift, axis=(0, 1))
        gap = ndimage.binary_erosion(laid) & level.observed  # gaps, not single columns
        observed = level.observed & ~gap
        z = np.where(observed, level.z, np.nan)
        rim = observed & ndimage.binary_dilation(~observed, structure=np.ones((3, 3), bool))
        ri, rj = np.nonzero(rim)
        gi, gj = np.nonzero(gap)
        reference = LinearNDInterpolator(np.column_stack([xs[ri], ys[rj]]), z[ri, rj])(
            np.column_stack([xs[gi], ys[gj]]))
        inside = np.isfinite(reference)  # the triangulation's hull
        chords.append((_fill_missing(z, observed)[gi, gj] - level.z[gi, gj])[inside])
        triangles.append((reference - level.z[gi, gj])[inside])
    chords, triangles = np.abs(np.concatenate(chords)), np.abs(np.concatenate(triangles))
    assert len(chords) > 5000
    assert chords.mean() <= 1.1 * triangles.mean()
    assert chords.mean() < 0.12  # metres
