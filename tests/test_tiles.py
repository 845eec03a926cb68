"""Tiled runs (core.tiles) give what a single run gives: the same blocks, the
same per-block volumes, closed and conforming ground and air across tiles."""
import re
import sys
import warnings

import numpy as np
import pytest

from core.errors import Cancelled, UrbanvoxError
from core.grid import GridWindow
from core.memory import check_memory
from core.pipeline import ReconstructionParams, reconstruct_point_cloud
from core.surface import AIR_REGION, GROUND_REGION
from core.tiles import TileOptions, initial_windows, plan_tiles
from core.topology import check_surface


def assert_same_blocks(single, tiled, rtol=1e-6):
    """Same count, same numbering, same voxel and mesh measures, same mesh nodes."""
    assert len(tiled.blocks) == len(single.blocks) > 0
    a, b = single.block_rows(), tiled.block_rows()
    for key in ("volume", "footprint_area", "height", "n_voxels", "surface_area"):
        assert [r[key] for r in a] == [r[key] for r in b], key
    for key in ("mesh_volume", "mesh_area", "roof_area", "facade_area"):
        x = np.array([r[key] for r in a])
        y = np.array([r[key] for r in b])
        assert np.all(np.abs(x - y) <= rtol * np.abs(x)), (key, np.max(np.abs(x - y) / np.abs(x)))
    np.testing.assert_array_equal(single.footprint_columns, tiled.footprint_columns)


def assert_closed(result):
    mesh = result.mesh.triangulated()
    for region in [int(b) for b in result.blocks.block_id] + [GROUND_REGION, AIR_REGION]:
        report = check_surface(mesh.closed_surface(region))
        assert report.ok, (region, report)


def same_nodes(single, tiled):
    """Distance between the final positions of the nodes both models share (by lattice index)."""
    h = single.grid.voxel_size
    np.testing.assert_allclose(single.grid.offset, tiled.grid.offset)
    dims = np.asarray(single.grid.shape) + 2

    def keyed(result):
        key = np.rint(result.surface.nodes / h).astype(np.int64)
        flat = key[:, 0] + dims[0] * (key[:, 1] + dims[1] * key[:, 2])
        order = np.argsort(flat)
        return flat[order], result.mesh.nodes[order]

    fa, pa = keyed(single)
    fb, pb = keyed(tiled)
    np.testing.assert_array_equal(fa, fb)
    return np.abs(pa - pb).max()


@pytest.fixture(scope="module")
def montpellier(shared_data):
    files = sorted((shared_data / "montpellier_ign").glob("*.laz"))
    assert len(files) == 6
    params = ReconstructionParams(voxel_size=1.0)
    single = reconstruct_point_cloud(files, params=params)
    tiled = reconstruct_point_cloud(files, params=params, tiles=TileOptions(tile_size=50.0))
    return single, tiled


@pytest.mark.slow
def test_montpellier_six_files_tiled_equals_single(montpellier):
    single, tiled = montpellier
    assert tiled.stats["tiles"] == 12  # 151 x 101 columns in 50 m tiles
    assert_same_blocks(single, tiled)
    # Every node, ground and air included, is where the single run puts it.
    assert same_nodes(single, tiled) < 1e-9
    assert len(tiled.mesh.quads) == len(single.mesh.quads)


@pytest.mark.slow
def test_montpellier_tiled_regions_are_closed_across_tiles(montpellier):
    _, tiled = montpellier
    assert_closed(tiled)


@pytest.mark.slow
def test_district_tiled_on_two_dask_workers(district):
    dask = pytest.importorskip("dask")
    pytest.importorskip("dask.distributed")
    params = ReconstructionParams(voxel_size=1.0, extent=district.district.extent)
    single = reconstruct_point_cloud(district.laz, params=params)
    # Every task carries its tile's points; Dask's warning of large tasks
    # (here at 1 kB, 10 MB by default) is not passed on to the user.
    with dask.config.set({"distributed.admin.large-graph-warning-threshold": "1kB"}), \
            warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        tiled = reconstruct_point_cloud(district.laz, params=params,
                                        tiles=TileOptions(tile_size=100.0, workers=2))
    assert not [w for w in caught if "large graph" in str(w.message)]
    assert tiled.stats["workers"] == 2 and tiled.stats["tiles"] == 9
    assert len(tiled.blocks) == len(district.expected_blocks)
    assert_same_blocks(single, tiled)
    assert_closed(tiled)


def test_a_block_crossing_tiles_is_owned_by_one_tile(district):
    # 40 m tiles cut most of the district's blocks; each must come out once, whole.
    params = ReconstructionParams(voxel_size=2.0, extent=district.district.extent, project=False)
    single = reconstruct_point_cloud(district.laz, params=params)
    tiled = reconstruct_point_cloud(district.laz, params=params, tiles=TileOptions(tile_size=40.0))
    assert tiled.stats["tiles"] >= 9
    assert_same_blocks(single, tiled, rtol=1e-9)
    assert same_nodes(single, tiled) < 1e-9


def test_a_merge_too_large_for_memory_is_refused_early(district):
    # 2 m voxels, 40 m tiles: 83 k faces, about 13 MB to merge; each tile's
    # grid and faces fit in 11 MB (the largest window has 22 k faces), the merge does not.
    params = ReconstructionParams(voxel_size=2.0, extent=district.district.extent, project=False,
                                  max_memory=11 * 2**20)
    seen = []
    with pytest.raises(UrbanvoxError, match=r"merged model is heading for about .* faces") as error:
        reconstruct_point_cloud(district.laz, params=params, tiles=TileOptions(tile_size=40.0),
                                progress=lambda f, m: seen.append(m))
    suggested = float(re.search(r"voxel size of at least ([\d.]+)", str(error.value)).group(1))
    assert suggested > 2.0
    # Refused once a tenth of the domain is done, not after the 49 tiles.
    assert sum(m.endswith("done") for m in seen) < 49 // 2
    # With the memory it needs, the same run goes through.
    enough = ReconstructionParams(voxel_size=2.0, extent=district.district.extent, project=False,
                                  max_memory=64 * 2**20)
    tiled = reconstruct_point_cloud(district.laz, params=enough, tiles=TileOptions(tile_size=40.0))
    assert len(tiled.surface.quads) * 160 < 64 * 2**20


def test_tiles_report_progress_in_order_and_honour_cancel(district):
    seen = []
    params = ReconstructionParams(voxel_size=2.0, extent=district.district.extent)
    reconstruct_point_cloud(district.laz, params=params, tiles=TileOptions(tile_size=100.0),
                            progress=lambda f, m: seen.append((f, m)))
    fractions = [f for f, _ in seen]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    assert any(m.startswith("Tile 9/9") for _, m in seen)
    calls = []
    with pytest.raises(Cancelled):
        reconstruct_point_cloud(district.laz, params=params, tiles=TileOptions(tile_size=100.0),
                                is_cancelled=lambda: calls.append(1) or len(calls) > 40)


def test_the_progress_bar_gives_each_tile_its_share_of_the_domain(district):
    """Tiles of unequal sizes move the bar by their areas, between the cutting and the merge."""
    from core.pipeline import READ_SHARE
    from core.tiles import AFTER_TILES, BEFORE_TILES

    seen = []
    params = ReconstructionParams(voxel_size=2.0, extent=district.district.extent)
    result = reconstruct_point_cloud(district.laz, params=params, tiles=TileOptions(tile_size=120.0),
                                     progress=lambda f, m: seen.append((f, m)))

    def bar(share: float) -> float:  # a share of the method's part of the bar (the reading has the rest)
        return READ_SHARE + (1 - READ_SHARE) * share

    at = {m: f for f, m in seen}
    assert at["Cutting the domain into tiles"] == pytest.approx(bar(0.0))
    assert at["Merging the tiles"] == pytest.approx(bar(1 - AFTER_TILES))
    done = [bar(BEFORE_TILES)] + [f for f, m in seen if re.fullmatch(r"Tile \d+/\d+ done", m)]
    cores = plan_tiles(result.grid.shape, 60)  # 120 m tiles of 2 m voxels
    areas = np.array([(i1 - i0) * (j1 - j0) for i0, j0, i1, j1 in cores], dtype=float)
    assert len(set(areas)) > 1 and len(done) == len(cores) + 1
    expected = areas / areas.sum() * (1 - BEFORE_TILES - AFTER_TILES) * (1 - READ_SHARE)
    np.testing.assert_allclose(sorted(np.diff(done)), sorted(expected), rtol=1e-9)


def test_workers_without_dask_say_what_to_install(district, monkeypatch):
    monkeypatch.setitem(sys.modules, "dask", None)
    monkeypatch.setitem(sys.modules, "dask.distributed", None)
    params = ReconstructionParams(voxel_size=2.0, extent=district.district.extent)
    with pytest.raises(UrbanvoxError, match=r"pip install 'dask\[distributed\]'"):
        reconstruct_point_cloud(district.laz, params=params, tiles=TileOptions(tile_size=100.0, workers=2))


def test_bad_tile_size_is_refused(district):
    with pytest.raises(UrbanvoxError, match="tile size"):
        reconstruct_point_cloud(district.laz, params=ReconstructionParams(voxel_size=2.0),
                                tiles=TileOptions(tile_size=-5.0))


@pytest.mark.parametrize("options", [dict(tile_size=float("nan")), dict(tile_size=0.0), dict(workers=-1),
                                     dict(workers=float("nan")), dict(workers=1.5)])
def test_bad_tile_options_are_refused_as_they_are_made(options):
    # Before a point is read (the command line makes them first), with the message, not a crash.
    with pytest.raises(UrbanvoxError, match="tile size must be|number of workers must be"):
        TileOptions(**options)
    assert TileOptions(workers=None).workers is None  # as 0: the tiles in this process


def test_memory_guard_suggests_a_tile_size():
    with pytest.raises(UrbanvoxError, match=r"tiles of at most (\d+) \(TILE_SIZE\)") as error:
        check_memory((6000, 6000, 100), 1.0, available=4 * 2**30, tile_hint=True)
    side = float(error.value.args[0].split("tiles of at most ")[1].split(" ")[0])
    # The suggested tile, with a halo of 12 voxels on each side, fits.
    check_memory((int(side) + 24, int(side) + 24, 100), 1.0, available=4 * 2**30)


def test_memory_guard_suggests_tiles_only_where_they_would_fit():
    """No tiles narrower than a few halos (a tiny voxel on tall data), none
    where the domain's columns alone exceed the memory; a count of voxels
    beyond int64 is still refused (it wrapped negative and let the run on)."""
    with pytest.raises(UrbanvoxError) as error:
        check_memory((6000001, 5999001, 1008203), 1e-5, available=4 * 2**30, tile_hint=True)
    assert "TILE_SIZE" not in str(error.value) and "voxel size of at least" in str(error.value)
    with pytest.raises(UrbanvoxError) as error:  # 10^12 columns: their ground level alone is terabytes
        check_memory((10**6, 10**6, 40), 1.0, available=4 * 2**30, tile_hint=True)
    assert "TILE_SIZE" not in str(error.value)


def test_a_tiled_domain_too_wide_for_its_columns_is_refused_before_allocating(district):
    from core.memory import check_column_memory

    params = ReconstructionParams(voxel_size=2.0, max_memory=2**16)  # 64 kiB: the district's columns need more
    with pytest.raises(UrbanvoxError, match="The ground level of the domain"):
        reconstruct_point_cloud(district.laz, params=params, tiles=TileOptions(tile_size=40.0))
    assert check_column_memory((100, 100), 2.0, available=2**20) == 640000


def test_plan_and_initial_windows_cover_the_domain():
    window = GridWindow(np.zeros(3), (95, 40, 10))
    cores = plan_tiles(window.shape, 30)
    covered = np.zeros((95, 40), int)
    for i0, j0, i1, j1 in cores:
        covered[i0:i1, j0:j1] += 1
    assert (covered == 1).all()
    mask = np.zeros((95, 40), bool)
    mask[25:70, 10:12] = True  # a long block anchored in the first tile
    windows = initial_windows(cores, 30, 4, window, mask)
    assert windows[0][2] >= 70 + 2 + 4  # the whole block, the two dilated columns and the halo
    assert windows[-1] == (86, 26, 95, 40)  # untouched: core and halo


def test_memory_guard_counts_the_surfaces_too(district):
    # The grid (4.4 M voxels, 16 B each) fits in 100 MB; the surfaces (400 B per face) do not.
    params = ReconstructionParams(voxel_size=1.0, extent=district.district.extent, max_memory=100 * 2**20)
    with pytest.raises(UrbanvoxError, match=r"surfaces \(\d+ faces\) need about .* tiles of at most \d+"):
        reconstruct_point_cloud(district.laz, params=params)


def test_mesh_input_tiled_equals_single(district):
    from core.pipeline import reconstruct_mesh

    params = ReconstructionParams(voxel_size=2.0, extent=district.district.extent)
    args = dict(crs=district.crs, ground_path=district.ground_stl, params=params)
    single = reconstruct_mesh(district.stl, **args)
    tiled = reconstruct_mesh(district.stl, tiles=TileOptions(tile_size=60.0), **args)
    assert tiled.stats["tiles"] == 25
    assert_same_blocks(single, tiled, rtol=1e-9)
    assert same_nodes(single, tiled) < 1e-9


def test_merge_keys_that_would_overflow_are_refused():
    # The merge numbers node copies by lattice node x 2 tiles + rank in 64 bits;
    # a domain whose numbers would wrap is refused (before its tiles run).
    from core.tile_merge import check_copy_keys

    check_copy_keys(GridWindow(np.zeros(3), (2000, 2000, 300)), 25)  # the 2 km city
    with pytest.raises(UrbanvoxError, match="larger tiles"):
        check_copy_keys(GridWindow(np.zeros(3), (10**7, 10**7, 1000)), 10**6)
