"""Both algorithms through ``qgis_process run`` on the real data of ../shared/data.

Skipped when the folder is absent. Loose checks only (some blocks, finite positive
attributes, the right CRS); the core's own tests hold the accuracy figures.
"""

import json
import math

import pytest
from qgis_helpers import gpkg_outputs, read_layer, run_json

pytestmark = pytest.mark.slow

# (file under ../shared/data, CRS parameter or None to take the header's, expected CRS authid,
#  block count range, total volume range in m³ at 1 m voxels). The ranges were set by looking at
#  oblique pictures of the results (core.preview): Delft's strip of 10 blocks with the church tower,
#  St-Barth's 9 houses, sample_c's single large block, Jura's 4 village houses.
POINT_CLOUDS = [
    ("delft_ahn3/ahn3_cropped_2.laz", "EPSG:28992", "EPSG:28992", (8, 12), (25e3, 40e3)),  # no CRS in the header
    ("ign_lidarprod/St_Barth_RGAF09_UTM20N_IGN_1988_SB_subset_100m.laz", "EPSG:5490", "EPSG:5490", (7, 11),
     (8e3, 14e3)),  # none either
    ("pdal/sample_c.las", "EPSG:32610", "EPSG:32610", (1, 2), (50e3, 70e3)),  # unknown CRS
    ("ign_lidarprod/870000_6618000.subset.postValidation.laz", None, "EPSG:2154", (3, 5), (2.5e3, 4e3)),
    *[
        (f"montpellier_ign/test_data_{tile}_LA93_IGN69.laz", None, "EPSG:2154", (1, 4), (1e3, 20e3))
        for tile in ("77050_627755", "77050_627760", "77055_627755", "77055_627760", "77060_627755", "77060_627760")
    ],
]


def run(qgis_process, algorithm, **parameters):
    """``qgis_process run``; the results of its JSON report."""
    proc, report = run_json(qgis_process, algorithm, **parameters)
    assert proc.returncode == 0 and report, (proc.stdout + proc.stderr)[-3000:]
    return report["results"]


def check_layers(results, gpkg, authid):
    count = results["BLOCK_COUNT"]
    assert count > 0
    for table in ("blocks", "footprints"):
        layer, features = read_layer(gpkg, table)
        assert len(features) == count
        assert layer.crs().authid() == authid, layer.crs().toWkt()
        for f in features:
            for name in ("volume", "footprint_area", "height", "surface_area"):
                assert math.isfinite(f[name]) and f[name] > 0, (table, name, f.attributes())
            assert not f.geometry().isEmpty()
    assert math.isfinite(results["TOTAL_VOLUME"]) and results["TOTAL_VOLUME"] > 0


@pytest.mark.parametrize("relative, crs, authid, counts, volumes", POINT_CLOUDS,
                         ids=[p[0].split("/")[-1] for p in POINT_CLOUDS])
def test_point_cloud(qgis_app, qgis_process, shared_data, tmp_path, relative, crs, authid, counts, volumes):
    path = shared_data / relative
    if not path.exists():
        pytest.skip(f"{path} not found")
    gpkg = tmp_path / "out.gpkg"
    parameters = {"INPUT": str(path), **gpkg_outputs(gpkg)}
    if crs:
        parameters["CRS"] = crs
    results = run(qgis_process, "urbanvox:reconstructfrompointcloud", **parameters)
    check_layers(results, gpkg, authid)
    assert counts[0] <= results["BLOCK_COUNT"] <= counts[1]
    assert volumes[0] <= results["TOTAL_VOLUME"] <= volumes[1]


def test_delft_without_crs_asks_for_one(processing, shared_data, tmp_path):
    from qgis.core import QgsProcessingException

    gpkg = tmp_path / "out.gpkg"
    with pytest.raises(QgsProcessingException, match="CRS"):
        processing.run(
            "urbanvox:reconstructfrompointcloud",
            {"INPUT": str(shared_data / "delft_ahn3/ahn3_cropped_2.laz"), **gpkg_outputs(gpkg)},
        )
    assert not gpkg.exists()


def test_zurich_lod2_mesh(qgis_app, qgis_process, shared_data, tmp_path):
    path = shared_data / "cityjson/zurich_subset_lod2_buildings.stl"
    if not path.exists():
        pytest.skip(f"{path} not found")
    gpkg = tmp_path / "out.gpkg"
    # 49 buildings scattered over 9 x 10 km: each cluster gets a grid of its own.
    parameters = {"INPUT": str(path), "CRS": "EPSG:2056", "VOXEL_SIZE": 1.0, **gpkg_outputs(gpkg)}
    results = run(qgis_process, "urbanvox:reconstructfrommesh", **parameters)
    check_layers(results, gpkg, "EPSG:2056")
    assert 46 <= results["BLOCK_COUNT"] <= 52
    assert 140e3 <= results["TOTAL_VOLUME"] <= 200e3


def test_zurich_cityjson_takes_its_crs_from_the_file(qgis_app, qgis_process, shared_data, tmp_path):
    """The CityJSON the STL above was made from, without a CRS parameter: its referenceSystem."""
    path = shared_data / "cityjson/zurich_subset_lod2.json"
    if not path.exists():
        pytest.skip(f"{path} not found")
    gpkg = tmp_path / "out.gpkg"
    results = run(qgis_process, "urbanvox:reconstructfrommesh", INPUT=str(path), VOXEL_SIZE=1.0,
                  **gpkg_outputs(gpkg))
    check_layers(results, gpkg, "EPSG:2056")
    assert results["BLOCK_COUNT"] == 49
    assert results["TOTAL_VOLUME"] == pytest.approx(170_480, rel=0.003)  # the core's (tests/test_cityjson.py)
    # Each block holds one of the file's 49 buildings, by identifier.
    buildings = sorted(key for key, value in json.loads(path.read_text())["CityObjects"].items()
                       if value["type"] == "Building")
    _, features = read_layer(gpkg, "blocks")
    assert sorted(f["building_ids"] for f in features) == buildings
    assert {f["n_buildings"] for f in features} == {1}


def test_rotterdam_cityjson_filled_up_to_its_roofs(qgis_app, qgis_process, shared_data, tmp_path):
    """Row houses without party walls: FILL_UNDER_ROOFS gives them their volume (core: 31,300 m³
    under the roofs; voxels at 1 m hold more)."""
    path = shared_data / "cityjson/rotterdam_subset.json"
    if not path.exists():
        pytest.skip(f"{path} not found")
    gpkg = tmp_path / "out.gpkg"
    results = run(qgis_process, "urbanvox:reconstructfrommesh", INPUT=str(path), CRS="EPSG:28992",
                  FILL_UNDER_ROOFS="true", VOXEL_SIZE=1.0, **gpkg_outputs(gpkg))
    check_layers(results, gpkg, "EPSG:28992")
    assert 31e3 < results["TOTAL_VOLUME"] < 37e3


def test_montpellier_six_files_tiled_on_two_workers(qgis_app, qgis_process, shared_data, tmp_path):
    """The six tiles as six INPUT values, once on one grid and once in 50 m tiles on two Dask
    workers: the same blocks with the same volumes."""
    files = sorted((shared_data / "montpellier_ign").glob("*.laz"))
    assert len(files) == 6
    runs = {}
    for name, extra in (("single", []), ("tiled", ["TILE_SIZE=50", "WORKERS=2"])):
        gpkg = tmp_path / f"{name}.gpkg"
        proc = qgis_process("--json", "run", "urbanvox:reconstructfrompointcloud", "--",
                            *(f"INPUT={f}" for f in files), *extra,
                            *(f"{k}={v}" for k, v in gpkg_outputs(gpkg).items()))
        assert proc.returncode == 0, (proc.stdout + proc.stderr)[-3000:]
        _, features = read_layer(gpkg, "blocks")
        runs[name] = sorted((f["block_id"], f["volume"], f["mesh_volume"]) for f in features)
    assert len(runs["single"]) == 10
    assert [r[:2] for r in runs["tiled"]] == [r[:2] for r in runs["single"]]
    for (_, _, a), (_, _, b) in zip(runs["single"], runs["tiled"]):
        assert abs(a - b) <= 1e-6 * abs(a)
