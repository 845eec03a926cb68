"""Both algorithms run through ``processing.run`` on the synthetic district (in-process QGIS)."""

import math
from pathlib import Path

import pytest
from qgis_helpers import gpkg_outputs, gpkg_sink, read_layer, recording_feedback

FIELDS = ["block_id", "height", "ground_z", "top_z", "footprint_area", "volume", "surface_area", "n_voxels"]


def check_outputs(results, gpkg, crs_authid):
    """Both layers hold BLOCK_COUNT blocks with sane attributes; returns the footprint features."""
    from qgis.core import QgsWkbTypes

    count = results["BLOCK_COUNT"]
    assert isinstance(count, int) and count > 0
    blocks, block_features = read_layer(gpkg, "blocks")
    footprints, footprint_features = read_layer(gpkg, "footprints")
    assert len(block_features) == len(footprint_features) == count
    assert blocks.wkbType() == QgsWkbTypes.Type.MultiPolygonZ
    assert footprints.wkbType() == QgsWkbTypes.Type.Polygon
    for layer in (blocks, footprints):
        assert layer.crs().authid() == crs_authid
        names = [f.name() for f in layer.fields()]
        assert names[1 : 1 + len(FIELDS)] == FIELDS  # a GPKG adds fid in front; the core may add more after
    total = 0.0
    for block, footprint in zip(block_features, footprint_features):
        assert block["block_id"] == footprint["block_id"]
        for name in ("height", "footprint_area", "volume", "surface_area"):
            assert math.isfinite(block[name]) and block[name] > 0, (name, block.attributes())
        assert block["top_z"] - block["ground_z"] == pytest.approx(block["height"], abs=1e-6)
        assert block["n_voxels"] > 0
        assert not block.geometry().isEmpty() and not footprint.geometry().isEmpty()
        # the footprint polygon is the union of the block's columns
        assert footprint.geometry().area() == pytest.approx(footprint["footprint_area"], rel=1e-6)
        total += block["volume"]
    assert results["TOTAL_VOLUME"] == pytest.approx(total, rel=1e-9)
    return footprint_features


def check_against_truth(footprints, district, volume_tolerance):
    """Most truth blocks above the thresholds are covered by one footprint; the total volume is close."""
    from qgis.core import QgsGeometry

    expected = district.expected_blocks
    shapes = [f.geometry() for f in footprints]

    def covered(block):
        truth = QgsGeometry.fromWkt(block.footprint_wkt)
        return any(shape.intersection(truth).area() >= 0.5 * truth.area() for shape in shapes)

    missed = [b.name for b in expected if not covered(b)]
    assert len(missed) <= 0.1 * len(expected), missed
    truth_volume = sum(b.volume for b in expected)
    volume = sum(f["volume"] for f in footprints)
    assert volume == pytest.approx(truth_volume, rel=volume_tolerance)


def test_point_cloud_on_the_synthetic_district(processing, district, tmp_path):
    gpkg = tmp_path / "pointcloud.gpkg"
    feedback = recording_feedback()
    results = processing.run(
        "urbanvox:reconstructfrompointcloud",
        {"INPUT": str(district.laz), "VOXEL_SIZE": 1.0, **gpkg_outputs(gpkg)},
        feedback=feedback,
    )
    footprints = check_outputs(results, gpkg, "EPSG:2056")  # from the LAZ header
    check_against_truth(footprints, district, volume_tolerance=0.15)
    assert feedback.progress and max(feedback.progress) == pytest.approx(100.0)
    assert feedback.texts  # the core's step messages
    assert feedback.warnings  # the district has trees over roofs and blocks below the thresholds


def test_a_french_qgis_shows_the_run_in_french(processing, district, tmp_path):
    """The core's step messages and the outputs' are translated as they are shown (core.progress)."""
    from qgis.PyQt.QtCore import QCoreApplication

    import urbanvox

    translator = urbanvox.load_translation("fr")
    assert translator is not None
    feedback = recording_feedback()
    try:
        processing.run("urbanvox:reconstructfrompointcloud",
                       {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0, "SMOOTHING_ITERATIONS": 3,
                        **gpkg_outputs(tmp_path / "fr.gpkg")}, feedback=feedback)
    finally:
        QCoreApplication.removeTranslator(translator)
    texts = feedback.texts
    assert {"Lecture du nuage de points", "Lissage (3 passes)", "Projection des nœuds sur les données",
            "Écriture des îlots et de leurs emprises"} <= set(texts), texts
    assert any(text.endswith(" îlots") for text in texts), texts
    assert any("îlots sous les seuils écartés" in warning for warning in feedback.warnings), feedback.warnings
    assert not [text for text in texts if text.startswith(("Reading", "Smoothing", "Projecting", "Writing"))]


def test_mesh_on_the_synthetic_district(processing, district, tmp_path):
    gpkg = tmp_path / "mesh.gpkg"
    results = processing.run(
        "urbanvox:reconstructfrommesh",
        {
            "INPUT": str(district.stl),
            "GROUND": str(district.ground_stl),
            "CRS": district.crs,
            "VOXEL_SIZE": 1.0,
            **gpkg_outputs(gpkg),
        },
    )
    footprints = check_outputs(results, gpkg, "EPSG:2056")
    check_against_truth(footprints, district, volume_tolerance=0.15)


def test_a_cityjson_building_at_the_level_of_detail_asked_for(processing, tmp_path):
    """A CityJSON building with a LoD 1.2 block 6 m high and a LoD 2.2 one 9 m high, its CRS in
    the file: the highest by default, LOD=1.2 when asked."""
    import json

    def box(height, first):
        corners = [[0, 0, 0], [20, 0, 0], [20, 12, 0], [0, 12, 0]]
        vertices = corners + [[x, y, height] for x, y, _ in corners]
        faces = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]]
        return vertices, [[[[first + i for i in face]] for face in faces]]  # a Solid: one shell of faces

    low, low_faces = box(6.0, 0)
    high, high_faces = box(9.0, 8)
    model = {"type": "CityJSON", "version": "2.0", "vertices": [[x + 2.6e6, y + 1.2e6, z] for x, y, z in low + high],
             "metadata": {"referenceSystem": "https://www.opengis.net/def/crs/EPSG/0/2056"},
             "CityObjects": {"b": {"type": "Building", "geometry": [
                 {"type": "Solid", "lod": "1.2", "boundaries": low_faces},
                 {"type": "Solid", "lod": "2.2", "boundaries": high_faces}]}}}
    path = tmp_path / "two_lods.city.json"
    path.write_text(json.dumps(model))
    heights = {}
    for lod in ("", "1.2"):
        gpkg = tmp_path / f"lod{lod.replace('.', '_')}.gpkg"
        results = processing.run("urbanvox:reconstructfrommesh",
                                 {"INPUT": str(path), "LOD": lod, "VOXEL_SIZE": 1.0, **gpkg_outputs(gpkg)})
        assert results["BLOCK_COUNT"] == 1
        _, blocks = read_layer(gpkg, "blocks")
        heights[lod] = blocks[0]["height"]
        # The building each block holds, by its CityJSON identifier (a text field).
        assert (blocks[0]["building_ids"], blocks[0]["n_buildings"]) == ("b", 1)
    assert heights == {"": 9.0, "1.2": 6.0}


def test_a_mesh_without_crs_is_refused_before_anything_is_written(processing, district, tmp_path):
    from qgis.core import QgsProcessingException

    gpkg = tmp_path / "nocrs.gpkg"
    with pytest.raises(QgsProcessingException, match=r"district.stl is a mesh, which carries no CRS: set the CRS"):
        processing.run("urbanvox:reconstructfrommesh", {"INPUT": str(district.stl), **gpkg_outputs(gpkg)})
    assert not gpkg.exists()


def test_thresholds_drop_blocks(processing, district, tmp_path):
    params = {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0}
    low = processing.run("urbanvox:reconstructfrompointcloud", {**params, **gpkg_outputs(tmp_path / "low.gpkg")})
    high = processing.run(
        "urbanvox:reconstructfrompointcloud",
        {**params, "MIN_HEIGHT": 20.0, **gpkg_outputs(tmp_path / "high.gpkg")},
    )
    assert 0 < high["BLOCK_COUNT"] < low["BLOCK_COUNT"]
    _, features = read_layer(tmp_path / "high.gpkg", "blocks")
    assert min(f["height"] for f in features) >= 20.0


def test_thresholds_that_drop_every_block_give_empty_layers(processing, district, tmp_path):
    # No block left: the layers are written, empty, with the ground (the
    # footprints of no column raised an IndexError once).
    gpkg = tmp_path / "none.gpkg"
    feedback = recording_feedback()
    results = processing.run(
        "urbanvox:reconstructfrompointcloud",
        {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0, "MIN_HEIGHT": 500.0, **gpkg_outputs(gpkg),
         "OUTPUT_GROUND": gpkg_sink(gpkg, "ground")},
        feedback=feedback,
    )
    assert results["BLOCK_COUNT"] == 0 and results["TOTAL_VOLUME"] == 0.0
    for table in ("blocks", "footprints"):
        assert read_layer(gpkg, table)[1] == []
    assert len(read_layer(gpkg, "ground")[1]) > 0
    assert any("No building block" in warning for warning in feedback.warnings)


def test_temporary_outputs_are_geopackage_files_not_memory_layers(processing, district, tmp_path):
    # A city's block surfaces as a memory layer hold 4-5 times their WKB in
    # QGIS's geometry objects for as long as the layer is open (the 1 km
    # synthetic city: a qgis_process run's peak 3.8 GB, 2.3 GB to a file).
    from qgis.core import QgsGraduatedSymbolRenderer, QgsProcessing, QgsProject

    # As the dialog runs it with its default outputs: the layers load when it ends.
    before = set(QgsProject.instance().mapLayers())
    results = processing.runAndLoadResults(
        "urbanvox:reconstructfrompointcloud",
        {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0, "OUTPUT_BLOCKS": QgsProcessing.TEMPORARY_OUTPUT,
         "OUTPUT_FOOTPRINTS": QgsProcessing.TEMPORARY_OUTPUT, "OUTPUT_GROUND": QgsProcessing.TEMPORARY_OUTPUT},
    )
    loaded = {layer.source(): layer for layer_id, layer in QgsProject.instance().mapLayers().items()
              if layer_id not in before}
    try:
        for name in ("OUTPUT_BLOCKS", "OUTPUT_FOOTPRINTS", "OUTPUT_GROUND"):
            path = results[name]
            assert isinstance(path, str) and path.endswith(".gpkg") and Path(path).is_file(), (name, path)
            layer = loaded[path]
            assert layer.isValid() and layer.providerType() == "ogr"
            if name != "OUTPUT_GROUND":
                assert layer.featureCount() == results["BLOCK_COUNT"] > 0
            else:
                assert layer.featureCount() > 0
        blocks = loaded[results["OUTPUT_BLOCKS"]]
        assert blocks.name() == "Building blocks (3D surfaces)"
        assert isinstance(blocks.renderer(), QgsGraduatedSymbolRenderer) and blocks.renderer3D() is not None
    finally:
        QgsProject.instance().removeMapLayers([layer.id() for layer in loaded.values()])
    # A memory layer asked for by name is still made.
    memory = processing.run(
        "urbanvox:reconstructfrompointcloud",
        {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0, "OUTPUT_BLOCKS": "memory:", "OUTPUT_FOOTPRINTS": "memory:"},
    )
    assert memory["OUTPUT_BLOCKS"].providerType() == "memory"
    assert memory["OUTPUT_BLOCKS"].featureCount() == memory["BLOCK_COUNT"] == results["BLOCK_COUNT"]


def test_crs_parameter_overrides_a_missing_header_crs(processing, district, tmp_path):
    las = tmp_path / "no_crs.las"
    district.district.write_las(las, density=2.0, crs=False)
    gpkg = tmp_path / "out.gpkg"
    results = processing.run(
        "urbanvox:reconstructfrompointcloud",
        {"INPUT": str(las), "CRS": "EPSG:2056", "VOXEL_SIZE": 2.0, **gpkg_outputs(gpkg)},
    )
    check_outputs(results, gpkg, "EPSG:2056")


def test_missing_crs_fails_clearly_and_writes_nothing(processing, district, tmp_path):
    from qgis.core import QgsProcessingException

    las = tmp_path / "no_crs.las"
    district.district.write_las(las, density=0.5, crs=False)
    gpkg = tmp_path / "out.gpkg"
    with pytest.raises(QgsProcessingException) as err:
        processing.run("urbanvox:reconstructfrompointcloud", {"INPUT": str(las), **gpkg_outputs(gpkg)})
    assert "CRS" in str(err.value)
    assert not gpkg.exists()


def test_cancel_stops_the_run_and_writes_nothing(processing, district, tmp_path):
    from qgis.core import QgsProcessingException

    gpkg = tmp_path / "out.gpkg"
    feedback = recording_feedback(cancel_at=15.0)
    with pytest.raises(QgsProcessingException) as err:
        processing.run(
            "urbanvox:reconstructfrompointcloud",
            {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0, **gpkg_outputs(gpkg)},
            feedback=feedback,
        )
    assert "ancel" in str(err.value)
    assert not gpkg.exists()


def test_a_missing_input_file_is_reported(processing, tmp_path):
    from qgis.core import QgsProcessingException

    with pytest.raises(QgsProcessingException):
        processing.run(
            "urbanvox:reconstructfrompointcloud",
            {"INPUT": str(tmp_path / "nothing.laz"), **gpkg_outputs(tmp_path / "out.gpkg")},
        )
    assert not (tmp_path / "out.gpkg").exists()


def test_smoothed_outputs_ground_layer_mesh_file_and_preview(processing, district, tmp_path):
    """Paper §4 outputs: smoothed blocks with mesh measures, the terrain, a mesh file and a PNG."""
    gpkg = tmp_path / "smoothed.gpkg"
    mesh = tmp_path / "district.obj"
    feedback = recording_feedback()
    results = processing.run(
        "urbanvox:reconstructfrompointcloud",
        {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0, "SMOOTHING_ITERATIONS": 3, "PROJECT": True,
         "QUALITY_THRESHOLD": 0.25, "EXTENT": "2600000,2600250,1200000,1200250 [EPSG:2056]",
         **gpkg_outputs(gpkg), "OUTPUT_GROUND": gpkg_sink(gpkg, "ground"), "OUTPUT_MESH": str(mesh)},
        feedback=feedback,
    )
    # Writing the outputs reports its own steps, after the method's, and the bar ends full (the
    # mesh file and its picture are written meanwhile, on a thread of their own).
    outputs_from = feedback.texts.index("Writing the blocks and footprints")
    assert feedback.texts[outputs_from:] == ["Writing the blocks and footprints", "Writing the ground",
                                             "Writing the mesh district.obj"]
    assert feedback.progress == sorted(feedback.progress) and feedback.progress[-1] == pytest.approx(100.0)
    _, blocks = read_layer(gpkg, "blocks")
    assert len(blocks) == results["BLOCK_COUNT"] > 40
    for feature in blocks:
        assert feature["min_quality"] >= 0.25
        assert 0.5 * feature["volume"] < feature["mesh_volume"] < 1.5 * feature["volume"]  # 2 m voxels: coarse
        assert feature["roof_area"] > 0 and feature["facade_area"] > 0
    _, ground = read_layer(gpkg, "ground")
    assert len(ground) >= 4 and all(f.geometry().constGet().is3D() for f in ground)
    groups = [line.split()[1] for line in mesh.read_text().splitlines() if line.startswith("g ")]
    assert groups.count("ground") == 1 and groups.count("air") == 1 and len(groups) == len(blocks) + 2
    preview = results["OUTPUT_PREVIEW"]
    assert preview.endswith(".png") and Path(preview).read_bytes()[:4] == b"\x89PNG"


def test_outputs_load_styled_by_height_with_a_3d_renderer(processing, district, tmp_path):
    from qgis.core import QgsGraduatedSymbolRenderer, QgsProcessingContext, QgsProject

    from urbanvox.processing_provider.styles import style_blocks, style_footprints, style_ground

    gpkg = tmp_path / "styled.gpkg"
    context = QgsProcessingContext()
    context.setProject(QgsProject.instance())
    results = processing.run(
        "urbanvox:reconstructfrompointcloud",
        {"INPUT": str(district.laz), "VOXEL_SIZE": 4.0, "SMOOTHING_ITERATIONS": 0, "PROJECT": False,
         **gpkg_outputs(gpkg), "OUTPUT_GROUND": gpkg_sink(gpkg, "ground")},
        context=context,
    )
    assert results["BLOCK_COUNT"] > 0
    blocks, _ = read_layer(gpkg, "blocks")
    style_blocks(blocks)
    renderer = blocks.renderer()
    assert isinstance(renderer, QgsGraduatedSymbolRenderer) and renderer.classAttribute() == "height"
    assert len(renderer.ranges()) == 5
    assert renderer.ranges()[-1].upperValue() == pytest.approx(max(f["height"] for f in blocks.getFeatures()))
    assert blocks.renderer3D() is not None
    ground, _ = read_layer(gpkg, "ground")
    style_ground(ground)
    assert ground.renderer3D() is not None
    footprints, _ = read_layer(gpkg, "footprints")
    style_footprints(footprints)
    assert footprints.renderer().symbol().color().alpha() < 255


def test_two_workers_from_a_background_task_as_the_dialog_runs_it(processing, district, tmp_path, monkeypatch):
    """The Processing dialog runs an algorithm in a task thread, in a process whose
    ``sys.executable`` is QGIS itself: the Dask workers still start (with QGIS's Python)
    and give the blocks of a run on one grid."""
    import multiprocessing
    import sys
    import time

    from qgis.core import (QgsApplication, QgsProcessingAlgRunnerTask, QgsProcessingContext,
                           QgsProcessingFeedback)
    from qgis.PyQt.QtCore import QCoreApplication

    base = {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0}
    single = processing.run("urbanvox:reconstructfrompointcloud", {**base, **gpkg_outputs(tmp_path / "single.gpkg")})
    monkeypatch.setattr(sys, "executable", "/usr/bin/qgis")
    started_with = []
    set_executable = multiprocessing.set_executable
    monkeypatch.setattr(multiprocessing, "set_executable",
                        lambda path: (started_with.append(path), set_executable(path)))
    gpkg = tmp_path / "tiled.gpkg"
    alg = QgsApplication.processingRegistry().createAlgorithmById("urbanvox:reconstructfrompointcloud")
    context, feedback = QgsProcessingContext(), QgsProcessingFeedback()
    task = QgsProcessingAlgRunnerTask(alg, {**base, "TILE_SIZE": 100.0, "WORKERS": 2, **gpkg_outputs(gpkg)},
                                      context, feedback)
    done = {}
    task.executed.connect(lambda ok, results: done.update(ok=ok, results=results))
    QgsApplication.taskManager().addTask(task)
    deadline = time.monotonic() + 600
    while "ok" not in done and time.monotonic() < deadline:
        QCoreApplication.processEvents()
        time.sleep(0.05)
    assert done.get("ok"), "the task failed or timed out"
    assert started_with and Path(started_with[-1]).name.startswith("python")  # a local cluster, not QGIS
    assert done["results"]["BLOCK_COUNT"] == single["BLOCK_COUNT"]
    _, tiled_blocks = read_layer(gpkg, "blocks")
    _, single_blocks = read_layer(tmp_path / "single.gpkg", "blocks")
    assert sorted((f["block_id"], f["volume"]) for f in tiled_blocks) == \
        sorted((f["block_id"], f["volume"]) for f in single_blocks)


def test_the_compiled_kernels_run_inside_qgis_with_the_same_blocks(processing, district, tmp_path, monkeypatch):
    # numba inside QGIS's Python, the plugin imported as urbanvox.core (its own
    # kernel cache): the same blocks as the numpy code. "always": the district
    # is below the size from which the kernels load on their own.
    from urbanvox.core import jit

    rows = {}
    for switch in ("0", "always"):
        monkeypatch.setenv("URBANVOX_JIT", switch)
        gpkg = tmp_path / f"jit-{switch}.gpkg"
        processing.run("urbanvox:reconstructfrompointcloud",
                       {"INPUT": str(district.laz), "VOXEL_SIZE": 1.0, **gpkg_outputs(gpkg)})
        _, features = read_layer(gpkg, "blocks")
        rows[switch] = sorted((f["block_id"], f["volume"], f["surface_area"], f["top_z"]) for f in features)
    assert len(rows["0"]) > 20 and rows["always"] == rows["0"]
    assert all(jit._loaded.get(name) is not None for name in jit.KERNELS), jit._loaded
    assert jit.failures == []
