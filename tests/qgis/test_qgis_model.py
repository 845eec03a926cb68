"""urbanvox inside a graphical model: a saved .model3 chaining the reconstruction with
a native QGIS algorithm runs headless through ``qgis_process run model.model3``."""
import sqlite3

from qgis_helpers import gpkg_sink, run_json


def build_model(path):
    from qgis.core import (QgsProcessingModelAlgorithm, QgsProcessingModelChildAlgorithm,
                           QgsProcessingModelChildParameterSource, QgsProcessingModelOutput,
                           QgsProcessingModelParameter, QgsProcessingParameterFile)

    model = QgsProcessingModelAlgorithm("tall blocks", "urbanvox tests")
    model.addModelParameter(QgsProcessingParameterFile("pointcloud", "Point cloud"),
                            QgsProcessingModelParameter("pointcloud"))
    reconstruct = QgsProcessingModelChildAlgorithm("urbanvox:reconstructfrompointcloud")
    reconstruct.setChildId("reconstruct")
    reconstruct.addParameterSources("INPUT", [QgsProcessingModelChildParameterSource.fromModelParameter("pointcloud")])
    for name, value in (("VOXEL_SIZE", 2.0), ("SMOOTHING_ITERATIONS", 1), ("PROJECT", False)):
        reconstruct.addParameterSources(name, [QgsProcessingModelChildParameterSource.fromStaticValue(value)])
    model.addChildAlgorithm(reconstruct)
    extract = QgsProcessingModelChildAlgorithm("native:extractbyexpression")
    extract.setChildId("tall")
    extract.addParameterSources("INPUT", [QgsProcessingModelChildParameterSource.fromChildOutput(
        "reconstruct", "OUTPUT_BLOCKS")])
    extract.addParameterSources("EXPRESSION", [QgsProcessingModelChildParameterSource.fromStaticValue(
        '"height" > 20')])
    output = QgsProcessingModelOutput("tall_blocks", "Tall blocks")
    output.setChildOutputName("OUTPUT")
    output.setChildId("tall")
    extract.setModelOutputs({"tall_blocks": output})
    model.addChildAlgorithm(extract)
    assert model.toFile(str(path))
    return model


def test_model_chaining_urbanvox_with_a_native_filter_runs_headless(qgis_app, urbanvox_plugin, qgis_process,
                                                                    district, tmp_path):
    model_path = tmp_path / "tall_blocks.model3"
    build_model(model_path)
    gpkg = tmp_path / "tall.gpkg"
    proc, report = run_json(qgis_process, str(model_path), pointcloud=district.laz,
                            **{"tall:tall_blocks": gpkg_sink(gpkg, "tall")})
    assert proc.returncode == 0, (proc.stdout + proc.stderr)[-3000:]
    with sqlite3.connect(gpkg) as db:
        heights = [h for (h,) in db.execute('SELECT height FROM "tall"')]
    expected = [b for b in district.expected_blocks if b.height > 20.5]
    assert heights and all(h > 20 for h in heights)
    assert len(heights) >= len(expected) - 2
