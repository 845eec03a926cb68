"""The edges of a run as QGIS gives it: an extent in another CRS, a folder as input, a cancel while the
outputs are written, a mesh file name that cannot be written, an unreachable Dask scheduler, the same
fields whatever the number of blocks, and the messages in QGIS's words and language."""

import json
import os
import shutil
from pathlib import Path

import pytest
from qgis_helpers import gpkg_outputs, gpkg_sink, read_layer, recording_feedback

#: A part of the synthetic district (EPSG:2056), as test_qgis_algorithms uses it.
DISTRICT_BOX = (2600000.0, 1200000.0, 2600250.0, 1200250.0)

#: Every field of a layer of blocks, after the GeoPackage's fid.
ALL_FIELDS = ["block_id", "height", "ground_z", "top_z", "footprint_area", "volume", "surface_area", "n_voxels",
              "mesh_volume", "mesh_area", "roof_area", "facade_area", "min_quality", "mean_quality", "mean_dist",
              "max_dist"]


def box_in(box, source, target):
    """The bounding box of ``box`` (xmin, ymin, xmax, ymax) of CRS ``source`` in CRS ``target``."""
    from qgis.core import QgsCoordinateReferenceSystem, QgsCoordinateTransform, QgsProject, QgsRectangle

    transform = QgsCoordinateTransform(QgsCoordinateReferenceSystem(source), QgsCoordinateReferenceSystem(target),
                                       QgsProject.instance())
    rect = transform.transformBoundingBox(QgsRectangle(*box))
    return rect.xMinimum(), rect.yMinimum(), rect.xMaximum(), rect.yMaximum()


def extent_text(box, crs):
    xmin, ymin, xmax, ymax = box
    return f"{xmin!r},{xmax!r},{ymin!r},{ymax!r} [{crs}]"


def footprints_within(gpkg, box, margin):
    """Whether every footprint of ``gpkg`` lies in ``box`` grown by ``margin``."""
    xmin, ymin, xmax, ymax = box
    for feature in read_layer(gpkg, "footprints")[1]:
        rect = feature.geometry().boundingBox()
        if (rect.xMinimum() < xmin - margin or rect.yMinimum() < ymin - margin
                or rect.xMaximum() > xmax + margin or rect.yMaximum() > ymax + margin):
            return False
    return True


# -- 1. the extent in another CRS --------------------------------------------------------------------


def test_an_extent_in_wgs84_is_transformed_into_the_point_clouds_crs(processing, district, tmp_path):
    """The extent in EPSG:4326 (as drawn on a map in WGS 84) is the same domain as in EPSG:2056, the
    CRS of the LAZ header: not degrees read as metres ("No ground point")."""
    common = {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0}
    native = processing.run("urbanvox:reconstructfrompointcloud", {
        **common, "EXTENT": extent_text(DISTRICT_BOX, "EPSG:2056"), **gpkg_outputs(tmp_path / "native.gpkg")})
    wgs84 = box_in(DISTRICT_BOX, "EPSG:2056", "EPSG:4326")
    results = processing.run("urbanvox:reconstructfrompointcloud", {
        **common, "EXTENT": extent_text(wgs84, "EPSG:4326"), **gpkg_outputs(tmp_path / "wgs84.gpkg")})
    # The WGS 84 box's own bounding box in EPSG:2056 is a little larger than the box it came from.
    assert abs(results["BLOCK_COUNT"] - native["BLOCK_COUNT"]) <= 3 and results["BLOCK_COUNT"] > 0
    assert footprints_within(tmp_path / "wgs84.gpkg", box_in(wgs84, "EPSG:4326", "EPSG:2056"), margin=2.0)
    # With the CRS parameter (here the same as the header's) it is that CRS the extent goes to.
    with_crs = processing.run("urbanvox:reconstructfrompointcloud", {
        **common, "CRS": "EPSG:2056", "EXTENT": extent_text(wgs84, "EPSG:4326"),
        **gpkg_outputs(tmp_path / "with_crs.gpkg")})
    assert with_crs["BLOCK_COUNT"] == results["BLOCK_COUNT"]


def test_an_extent_in_wgs84_is_transformed_into_a_city_models_crs(processing, tmp_path):
    """The mesh algorithm, the CRS read from the CityJSON file's referenceSystem (no CRS parameter):
    of two buildings 200 m apart, the extent round the first keeps it alone."""
    city = write_city_model(tmp_path / "two.city.json", origins=((0.0, 0.0), (200.0, 0.0)))
    whole = processing.run("urbanvox:reconstructfrommesh",
                           {"INPUT": str(city), "VOXEL_SIZE": 1.0, **gpkg_outputs(tmp_path / "whole.gpkg")})
    first = (2.6e6 - 30.0, 1.2e6 - 30.0, 2.6e6 + 50.0, 1.2e6 + 42.0)
    wgs84 = box_in(first, "EPSG:2056", "EPSG:4326")
    results = processing.run("urbanvox:reconstructfrommesh", {
        "INPUT": str(city), "VOXEL_SIZE": 1.0, "EXTENT": extent_text(wgs84, "EPSG:4326"),
        **gpkg_outputs(tmp_path / "first.gpkg")})
    assert whole["BLOCK_COUNT"] == 2 and results["BLOCK_COUNT"] == 1
    assert footprints_within(tmp_path / "first.gpkg", first, margin=2.0)


# -- 2. a cancel while the outputs are written -------------------------------------------------------


@pytest.mark.parametrize("cancel_at", [84.0, 90.0, 92.0])
def test_a_cancel_while_the_outputs_are_written_stops_and_leaves_none(processing, district, tmp_path, cancel_at):
    """Cancelled while the blocks (80-87 %), the ground (88-92 %) or the mesh (92 %) are written: the
    run stops with the cancel's message, and no file it wrote is left."""
    from qgis.core import QgsProcessingException

    gpkg = tmp_path / "out.gpkg"
    mesh = tmp_path / "district.msh"
    feedback = recording_feedback(cancel_at=cancel_at)
    with pytest.raises(QgsProcessingException, match="Cancelled; no output was written"):
        processing.run("urbanvox:reconstructfrompointcloud",
                       {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0, **gpkg_outputs(gpkg),
                        "OUTPUT_GROUND": gpkg_sink(gpkg, "ground"), "OUTPUT_MESH": str(mesh)},
                       feedback=feedback)
    assert max(feedback.progress) < 100.0
    assert sorted(os.listdir(tmp_path)) == []


def run_failing_in_the_mesh_writer(processing, district, tmp_path, monkeypatch, write_mesh, error):
    """A run with a mesh file ``mesh.msh``, whose ``Reconstruction.write_mesh`` is ``write_mesh``:
    it fails with ``error`` (a pattern) once the layers are written, and leaves no file."""
    from qgis.core import QgsProcessingException

    from urbanvox.core.reconstruction import Reconstruction

    monkeypatch.setattr(Reconstruction, "write_mesh", write_mesh)
    gpkg = tmp_path / "out.gpkg"
    with pytest.raises(QgsProcessingException, match=error):
        processing.run("urbanvox:reconstructfrompointcloud",
                       {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0, **gpkg_outputs(gpkg),
                        "OUTPUT_MESH": str(tmp_path / "mesh.msh")})
    assert sorted(os.listdir(tmp_path)) == []


def test_a_cancel_inside_the_mesh_writer_stops_the_run_and_leaves_none(processing, district, tmp_path, monkeypatch):
    """The mesh thread gives the core writer the feedback's cancel check: cancelled while the .msh's
    rows are written (the writer's third check), the run says so and leaves no file."""
    from urbanvox.core.reconstruction import Reconstruction

    write_mesh = Reconstruction.write_mesh
    checks = []

    def cancelled_inside(self, path, binary=False, is_cancelled=None):
        assert is_cancelled is not None and not is_cancelled()  # the feedback's, not cancelled yet
        return write_mesh(self, path, binary, is_cancelled=lambda: len(checks.append(1) or checks) >= 3)

    run_failing_in_the_mesh_writer(processing, district, tmp_path, monkeypatch, cancelled_inside,
                                   "Cancelled; no output was written")
    assert len(checks) == 3


def test_a_cancel_while_writing_keeps_the_other_layers_of_an_existing_geopackage(processing, district, tmp_path):
    """Outputs written as layers of a GeoPackage that held a layer before: the cancel drops the layers
    this run added, the file and its own layer stay."""
    from qgis.core import QgsProcessingException

    from osgeo import ogr, osr

    gpkg = tmp_path / "project.gpkg"
    dataset = ogr.GetDriverByName("GPKG").CreateDataSource(str(gpkg))
    dataset.CreateLayer("kept", osr.SpatialReference(), ogr.wkbPoint)
    dataset = None  # written
    with pytest.raises(QgsProcessingException, match="Cancelled"):
        processing.run("urbanvox:reconstructfrompointcloud",
                       {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0, **gpkg_outputs(gpkg)},
                       feedback=recording_feedback(cancel_at=84.0))
    dataset = ogr.Open(str(gpkg))
    assert [dataset.GetLayerByIndex(i).GetName() for i in range(dataset.GetLayerCount())] == ["kept"]


# -- 3. the mesh file's name, checked before the run -------------------------------------------------


@pytest.mark.parametrize("name, message", [
    ("mesh.txt", r"has no mesh extension: end its name with one of \.msh, \.vtu, \.obj, \.stl, \.ply"),
    ("mesh", r"has no mesh extension"),
    ("missing/mesh.msh", r"folder of the mesh file .* does not exist"),
    ("folder.msh", r"is a folder"),
])
def test_a_mesh_file_name_that_cannot_be_written_stops_the_run_before_it_starts(processing, district, tmp_path,
                                                                                 name, message):
    from qgis.core import QgsProcessingException

    (tmp_path / "folder.msh").mkdir()
    gpkg = tmp_path / "out.gpkg"
    feedback = recording_feedback()
    with pytest.raises(QgsProcessingException, match=message):
        processing.run("urbanvox:reconstructfrompointcloud",
                       {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0, **gpkg_outputs(gpkg),
                        "OUTPUT_MESH": str(tmp_path / name)}, feedback=feedback)
    assert not gpkg.exists()
    assert not [p for p in feedback.progress if p > 0]  # refused before the method


def test_the_mesh_suffixes_checked_are_those_the_core_writes(urbanvox_plugin):
    from urbanvox.core.export import MESH_FORMATS
    from urbanvox.processing_provider.algorithms.outputs import MESH_SUFFIXES

    assert sorted(MESH_SUFFIXES) == sorted(MESH_FORMATS)


def test_a_mesh_file_that_fails_while_written_leaves_no_layer(processing, district, tmp_path, monkeypatch):
    """An error of the mesh's writer (a full disk) comes once the layers are written, naming the file;
    the layers this run wrote are removed with it, and no thread of it is left."""
    import threading

    def full_disk(self, path, binary=False, is_cancelled=None):
        raise OSError(28, "No space left on device")

    run_failing_in_the_mesh_writer(processing, district, tmp_path, monkeypatch, full_disk,
                                   "Could not write .*mesh.msh: .*No space left")
    assert not any(thread.name.startswith("urbanvox-mesh") for thread in threading.enumerate())


# -- 4. the Dask scheduler ---------------------------------------------------------------------------


@pytest.mark.parametrize("address", ["tcp://127.0.0.1:1", "notanaddress"])
def test_an_unreachable_dask_scheduler_says_what_to_do(processing, district, tmp_path, address):
    pytest.importorskip("distributed")
    import dask

    from qgis.core import QgsProcessingException

    gpkg = tmp_path / "out.gpkg"
    with dask.config.set({"distributed.comm.timeouts.connect": "2s"}):  # Dask's own: 30 s
        with pytest.raises(QgsProcessingException) as err:
            processing.run("urbanvox:reconstructfrompointcloud",
                           {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0, "TILE_SIZE": 50.0, "SCHEDULER": address,
                            **gpkg_outputs(gpkg)})
    message = str(err.value)
    assert f"Could not connect to the Dask scheduler at {address}" in message
    assert "Check that the scheduler is running" in message and "leave the Dask scheduler address empty" in message
    assert not gpkg.exists()


def test_a_scheduler_for_data_that_fit_in_one_tile_is_not_said_to_be_used(processing, district, tmp_path):
    feedback = recording_feedback()
    results = processing.run("urbanvox:reconstructfrompointcloud",
                             {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0, "TILE_SIZE": 5000.0,
                              "SCHEDULER": "tcp://127.0.0.1:1", **gpkg_outputs(tmp_path / "out.gpkg")},
                             feedback=feedback)
    assert results["BLOCK_COUNT"] > 0
    assert not [info for info in feedback.infos if "on tcp://" in info], feedback.infos
    assert any("fit in one tile of 5000.0 m: reconstructed in this process, without tcp://127.0.0.1:1" in info
               for info in feedback.infos), feedback.infos


def test_tiles_are_said_to_run_where_they_run(processing, district, tmp_path):
    feedback = recording_feedback()
    processing.run("urbanvox:reconstructfrompointcloud",
                   {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0, "TILE_SIZE": 100.0,
                    **gpkg_outputs(tmp_path / "out.gpkg")}, feedback=feedback)
    assert "Tiles of 100.0 m on 1 worker(s)" in feedback.infos


# -- 5. the same fields whatever the number of blocks ------------------------------------------------


def field_names(gpkg, table):
    return [field.name() for field in read_layer(gpkg, table)[0].fields()][1:]  # after the GeoPackage's fid


def test_an_empty_result_has_the_fields_of_a_full_one(processing, district, tmp_path):
    common = {"INPUT": str(district.laz), "VOXEL_SIZE": 2.0}
    processing.run("urbanvox:reconstructfrompointcloud", {**common, **gpkg_outputs(tmp_path / "full.gpkg")})
    empty = processing.run("urbanvox:reconstructfrompointcloud",
                           {**common, "MIN_HEIGHT": 500.0, **gpkg_outputs(tmp_path / "empty.gpkg")})
    assert empty["BLOCK_COUNT"] == 0
    for table in ("blocks", "footprints"):
        assert field_names(tmp_path / "full.gpkg", table) == ALL_FIELDS
        assert field_names(tmp_path / "empty.gpkg", table) == ALL_FIELDS


def write_city_model(path, roof_only=False, origins=((0.0, 0.0),)):
    """A CityJSON file (EPSG:2056) of a building, a 20 x 12 x 9 m box, at each of ``origins`` (m from
    2600000, 1200000); ``roof_only``: their roofs and floors without walls, as a city model whose
    walls are missing."""
    corners = [[0, 0, 0], [20, 0, 0], [20, 12, 0], [0, 12, 0]]
    box = corners + [[x, y, 9.0] for x, y, _ in corners]
    faces = [[0, 3, 2, 1], [4, 5, 6, 7]] + ([] if roof_only else [[0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6],
                                                                    [3, 0, 4, 7]])
    vertices, objects = [], {}
    for n, (dx, dy) in enumerate(origins):
        first = len(vertices)
        vertices += [[x + dx + 2.6e6, y + dy + 1.2e6, z] for x, y, z in box]
        objects[f"b{n}"] = {"type": "Building", "geometry": [
            {"type": "MultiSurface", "lod": "2.2", "boundaries": [[[first + i for i in face]] for face in faces]}]}
    model = {"type": "CityJSON", "version": "2.0", "vertices": vertices,
             "metadata": {"referenceSystem": "https://www.opengis.net/def/crs/EPSG/0/2056"},
             "CityObjects": objects}
    path.write_text(json.dumps(model))
    return path


def test_a_city_models_layers_have_its_building_fields_with_or_without_blocks(processing, tmp_path):
    city = write_city_model(tmp_path / "box.city.json")
    for name, min_height in (("full", 2.5), ("empty", 500.0)):
        results = processing.run("urbanvox:reconstructfrommesh",
                                 {"INPUT": str(city), "VOXEL_SIZE": 1.0, "MIN_HEIGHT": min_height,
                                  **gpkg_outputs(tmp_path / f"{name}.gpkg")})
        assert results["BLOCK_COUNT"] == (1 if name == "full" else 0)
        for table in ("blocks", "footprints"):
            assert field_names(tmp_path / f"{name}.gpkg", table) == ALL_FIELDS + ["building_ids", "n_buildings"]


# -- 6. a folder as input ----------------------------------------------------------------------------


def test_a_folder_of_las_files_is_read_as_the_files_in_it(processing, district, tmp_path):
    folder = tmp_path / "tiles"
    folder.mkdir()
    shutil.copy(district.laz, folder / "district.LAZ")
    (folder / "readme.txt").write_text("not a point cloud")
    common = {"VOXEL_SIZE": 2.0}
    from_file = processing.run("urbanvox:reconstructfrompointcloud",
                               {**common, "INPUT": str(district.laz), **gpkg_outputs(tmp_path / "file.gpkg")})
    from_folder = processing.run("urbanvox:reconstructfrompointcloud",
                                 {**common, "INPUT": str(folder), **gpkg_outputs(tmp_path / "folder.gpkg")})
    assert from_folder["BLOCK_COUNT"] == from_file["BLOCK_COUNT"] > 0
    assert from_folder["TOTAL_VOLUME"] == pytest.approx(from_file["TOTAL_VOLUME"])


def test_a_missing_input_or_an_empty_folder_says_so(processing, tmp_path):
    from qgis.core import QgsProcessingException

    (tmp_path / "empty").mkdir()
    outputs = gpkg_outputs(tmp_path / "out.gpkg")
    with pytest.raises(QgsProcessingException, match="File or folder not found: .*nothing.laz"):
        processing.run("urbanvox:reconstructfrompointcloud", {"INPUT": str(tmp_path / "nothing.laz"), **outputs})
    with pytest.raises(QgsProcessingException, match="The folder .*empty holds no LAS/LAZ file"):
        processing.run("urbanvox:reconstructfrompointcloud", {"INPUT": str(tmp_path / "empty"), **outputs})
    assert not (tmp_path / "out.gpkg").exists()


# -- 7. the messages in QGIS's words and language ----------------------------------------------------


def test_the_run_summary_and_a_core_warning_are_in_french_and_name_the_dialogs_parameter(processing, tmp_path):
    """The summary lines are translated; the hollow blocks' warning names the parameter as the
    dialog shows it, not the command line's flag."""
    from qgis.PyQt.QtCore import QCoreApplication

    import urbanvox

    city = write_city_model(tmp_path / "roofs.city.json", roof_only=True)
    translator = urbanvox.load_translation("fr")
    assert translator is not None
    feedback = recording_feedback()
    try:
        processing.run("urbanvox:reconstructfrommesh",
                       {"INPUT": str(city), "VOXEL_SIZE": 1.0, **gpkg_outputs(tmp_path / "out.gpkg"),
                        "OUTPUT_MESH": str(tmp_path / "out.obj")}, feedback=feedback)
    finally:
        QCoreApplication.removeTranslator(translator)
    hollow = [warning for warning in feedback.warnings if "FILL_UNDER_ROOFS" in warning]
    assert hollow and "--fill-under-roofs" not in hollow[0], feedback.warnings
    assert "\"Remplir chaque colonne jusqu'à son toit\" (FILL_UNDER_ROOFS)" in hollow[0], hollow
    assert any(info.startswith("Maillage écrit dans ") for info in feedback.infos), feedback.infos
    assert any(" îlots bâtis, volume total " in info for info in feedback.infos), feedback.infos
    assert not [info for info in feedback.infos if "building blocks" in info or "Mesh written" in info]
