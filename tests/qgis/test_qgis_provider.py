"""The plugin, the provider and the algorithms' definitions, as QGIS sees them (no run)."""

import configparser
from pathlib import Path

import pytest
from qgis_helpers import gpkg_outputs

REPO_ROOT = Path(__file__).resolve().parents[2]
ALGORITHMS = {"urbanvox:reconstructfrompointcloud", "urbanvox:reconstructfrommesh"}
SHARED = ["VOXEL_SIZE", "MIN_HEIGHT", "MIN_FOOTPRINT", "MIN_VOLUME", "EXTENT", "SMOOTHING_ITERATIONS", "PROJECT",
          "QUALITY_THRESHOLD", "TILE_SIZE", "WORKERS", "SCHEDULER", "MESH_BINARY", "OUTPUT_BLOCKS", "OUTPUT_FOOTPRINTS",
          "OUTPUT_GROUND", "OUTPUT_MESH"]


def algorithm(alg_id):
    from qgis.core import QgsApplication

    alg = QgsApplication.processingRegistry().algorithmById(alg_id)
    assert alg is not None, alg_id
    return alg


def test_metadata_declares_a_processing_plugin_for_qgis_3_22_to_4():
    meta = configparser.ConfigParser()
    meta.read(REPO_ROOT / "metadata.txt", encoding="utf-8")
    general = meta["general"]
    assert general["name"] == "urbanvox"
    assert general["hasProcessingProvider"] == "yes"
    assert general["qgisMinimumVersion"] == "3.22"
    assert general["qgisMaximumVersion"] == "4.99"
    for key in ("description", "about", "version", "author", "email", "repository", "tracker", "category"):
        assert general[key].strip(), key
    assert "pip install" in general["about"]
    assert (REPO_ROOT / general["icon"]).is_file()


def test_provider_is_registered_with_both_algorithms(urbanvox_plugin):
    from qgis.core import QgsApplication

    provider = QgsApplication.processingRegistry().providerById("urbanvox")
    assert provider.name() == "urbanvox"
    assert not provider.icon().isNull()
    assert {a.id() for a in provider.algorithms()} == ALGORITHMS
    for alg in provider.algorithms():
        assert alg.displayName() and "<p>" in alg.shortHelpString()
        assert not alg.icon().isNull()


def test_unload_removes_the_provider_and_init_restores_it(urbanvox_plugin):
    from qgis.core import QgsApplication

    registry = QgsApplication.processingRegistry()
    urbanvox_plugin.unload()
    assert registry.providerById("urbanvox") is None
    urbanvox_plugin.initProcessing()
    urbanvox_plugin.initProcessing()  # idempotent: initGui() calls it again in the desktop
    assert registry.providerById("urbanvox") is not None


@pytest.mark.parametrize("alg_id", sorted(ALGORITHMS))
def test_shared_parameters_and_outputs(urbanvox_plugin, alg_id):
    from qgis.core import QgsProcessingParameterDefinition

    alg = algorithm(alg_id)
    names = [p.name() for p in alg.parameterDefinitions()]
    assert names[0] == "INPUT" and "CRS" in names
    assert names[-len(SHARED):] == SHARED
    voxel = alg.parameterDefinition("VOXEL_SIZE")
    assert voxel.defaultValue() == 1.0 and voxel.minimum() == 0.05
    assert alg.parameterDefinition("MIN_HEIGHT").defaultValue() == 2.5
    assert alg.parameterDefinition("MIN_FOOTPRINT").defaultValue() == 10.0
    assert alg.parameterDefinition("MIN_VOLUME").defaultValue() == 20.0
    assert alg.parameterDefinition("SMOOTHING_ITERATIONS").defaultValue() == 3
    assert alg.parameterDefinition("PROJECT").defaultValue() is True
    assert alg.parameterDefinition("QUALITY_THRESHOLD").defaultValue() == 0.2
    for optional in ("EXTENT", "OUTPUT_GROUND", "OUTPUT_MESH"):
        assert alg.parameterDefinition(optional).flags() & QgsProcessingParameterDefinition.Flag.FlagOptional
    assert {o.name() for o in alg.outputDefinitions()} >= {"OUTPUT_BLOCKS", "OUTPUT_FOOTPRINTS", "OUTPUT_GROUND",
                                                           "OUTPUT_MESH", "OUTPUT_PREVIEW", "BLOCK_COUNT",
                                                           "TOTAL_VOLUME"}
    assert alg.outputDefinition("BLOCK_COUNT").type() == "outputNumber"


def test_point_cloud_parameters(urbanvox_plugin):
    from qgis.core import QgsProcessingParameterDefinition

    alg = algorithm("urbanvox:reconstructfrompointcloud")
    from qgis.core import QgsProcessing

    # Several files at once (a tile collection): a multiple-input parameter of files.
    assert alg.parameterDefinition("INPUT").type() == "multilayer"
    assert alg.parameterDefinition("INPUT").layerType() == QgsProcessing.SourceType.TypeFile
    for name in ("TILE_SIZE", "WORKERS", "SCHEDULER", "MESH_BINARY"):
        assert alg.parameterDefinition(name).flags() & QgsProcessingParameterDefinition.Flag.FlagAdvanced
    assert alg.parameterDefinition("MESH_BINARY").defaultValue() is False
    assert alg.parameterDefinition("TILE_SIZE").defaultValue() == 0
    assert alg.parameterDefinition("CRS").flags() & QgsProcessingParameterDefinition.Flag.FlagOptional
    assert alg.parameterDefinition("GROUND_CLASSES").defaultValue() == "2"
    assert alg.parameterDefinition("BUILDING_CLASSES").defaultValue() == "6"


def test_the_toolbox_search_finds_the_algorithms_by_their_inputs(urbanvox_plugin):
    mesh, cloud = algorithm("urbanvox:reconstructfrommesh"), algorithm("urbanvox:reconstructfrompointcloud")
    assert {"cityjson", "citygml", "stl", "voxel", "cfd"} <= set(mesh.tags())
    assert {"lidar", "laz", "point cloud", "voxel", "finite element"} <= set(cloud.tags())
    assert "lidar" not in mesh.tags() and "cityjson" not in cloud.tags() and "" not in mesh.tags()


def test_mesh_parameters(urbanvox_plugin):
    from qgis.core import QgsProcessingParameterDefinition

    optional = QgsProcessingParameterDefinition.Flag.FlagOptional
    alg = algorithm("urbanvox:reconstructfrommesh")
    assert "*.stl" in alg.parameterDefinition("INPUT").fileFilter()
    assert "*.json" in alg.parameterDefinition("INPUT").fileFilter()  # CityJSON
    assert "CityJSON" in alg.parameterDefinition("INPUT").help() and "STL" in alg.parameterDefinition("CRS").help()
    assert alg.parameterDefinition("GROUND").flags() & optional
    # Optional: a CityJSON file names its own; an STL without it stops with a message (test_qgis_algorithms).
    assert alg.parameterDefinition("CRS").flags() & optional
    lod = alg.parameterDefinition("LOD")
    assert lod.flags() & optional and lod.flags() & QgsProcessingParameterDefinition.Flag.FlagAdvanced
    fill = alg.parameterDefinition("FILL_UNDER_ROOFS")
    assert fill.defaultValue() is False and fill.flags() & QgsProcessingParameterDefinition.Flag.FlagAdvanced


def test_missing_python_package_gives_the_pip_command(processing, district, tmp_path, monkeypatch):
    from qgis.core import QgsProcessingException

    from urbanvox.processing_provider.algorithms.reconstruct_point_cloud import ReconstructFromPointCloud

    monkeypatch.setattr(
        ReconstructFromPointCloud,
        "requiredModules",
        lambda self, parameters, context: ("numpy", "no_such_module_urbanvox"),
    )
    out = tmp_path / "out.gpkg"
    with pytest.raises(QgsProcessingException) as err:
        processing.run("urbanvox:reconstructfrompointcloud", {"INPUT": str(district.laz), **gpkg_outputs(out)})
    assert "no_such_module_urbanvox" in str(err.value)
    assert "pip install" in str(err.value) and "numpy==" in str(err.value)
    assert not out.exists()


def test_field_values_are_plain_python_numbers(urbanvox_plugin):
    import numpy as np

    from urbanvox.processing_provider.algorithms.outputs import (BLOCK_FIELDS, CITY_FIELDS, block_attributes,
                                                                 field_kinds)

    row = {name: (np.int64(3) if kind != "double" else np.float32(1.5)) for name, kind in BLOCK_FIELDS}
    row.update(mesh_volume=2.5, max_dist=float("nan"), extra_count=7, building_ids="a;b")
    kinds = field_kinds([row], city_model=True)
    # The fixed fields whatever the rows hold (n_buildings missing here: NULL), then the rows' others.
    assert kinds == list(BLOCK_FIELDS) + list(CITY_FIELDS) + [("extra_count", "long")]
    values = block_attributes(row, kinds)
    names = [name for name, _ in kinds]
    assert [type(v) for v in values[: len(BLOCK_FIELDS)]] == [
        type(None) if name == "max_dist" else int if kind != "double" else float for name, kind in BLOCK_FIELDS
    ]
    assert values[names.index("mesh_volume")] == 2.5 and values[names.index("max_dist")] is None
    assert values[len(BLOCK_FIELDS):] == ["a;b", None, 7]
    assert field_kinds([]) == list(BLOCK_FIELDS)  # no block: the same fields
    assert field_kinds([]) == list(BLOCK_FIELDS)


@pytest.mark.parametrize("alg_id", sorted(ALGORITHMS))
def test_every_parameter_has_help_and_the_algorithm_a_help_url(urbanvox_plugin, alg_id):
    alg = algorithm(alg_id)
    for definition in alg.parameterDefinitions():
        assert len(definition.help()) > 10, definition.name()
    assert alg.helpUrl().startswith("file://") and alg.helpUrl().endswith("README.md#use-in-qgis")
    assert "Catmull-Clark" in alg.shortHelpString()
    assert 'href="file://' in alg.shortHelpString() and "<img" in alg.shortHelpString()


def test_french_qgis_shows_translated_names(qgis_process):
    """QGIS in French (the locale of the environment) lists the algorithms in French."""
    import os
    import subprocess

    env = {**os.environ, "LANG": "fr_FR.UTF-8", "LC_ALL": "fr_FR.UTF-8", "LANGUAGE": "fr"}
    listed = subprocess.run([str(REPO_ROOT / "scripts" / "qgis-process"), "list"], env=env,
                            capture_output=True, text=True, timeout=300)
    assert "Reconstruire les îlots bâtis à partir d'un nuage de points" in listed.stdout, listed.stdout[-2000:]


@pytest.mark.parametrize("language, name", [("fr", "Reconstruire les îlots bâtis à partir d'un maillage"),
                                            ("de", "Gebäudeblöcke aus einem Netz rekonstruieren")])
def test_every_string_is_translated(urbanvox_plugin, language, name):
    import xml.etree.ElementTree as ET

    from qgis.PyQt.QtCore import QCoreApplication

    ts = ET.parse(REPO_ROOT / "i18n" / f"urbanvox_{language}.ts")
    assert not [m for m in ts.iter("translation") if m.get("type") == "unfinished" or not m.text]
    import urbanvox

    translator = urbanvox.load_translation(language)
    try:
        assert translator is not None
        assert algorithm("urbanvox:reconstructfrommesh").displayName() == name
    finally:
        QCoreApplication.removeTranslator(translator)


def test_tile_parameters_become_tile_options(urbanvox_plugin):
    from qgis.core import QgsProcessingContext

    alg = algorithm("urbanvox:reconstructfrompointcloud")
    context = QgsProcessingContext()
    assert alg.tileOptions({"TILE_SIZE": 0, "WORKERS": 0}, context) is None
    options = alg.tileOptions({"TILE_SIZE": 120, "WORKERS": 3}, context)
    assert (options.tile_size, options.workers, options.scheduler) == (120.0, 3, None)
    # Several workers need several tiles: the default size is taken.
    assert alg.tileOptions({"TILE_SIZE": 0, "WORKERS": 2}, context).tile_size == 250.0
    assert alg.tileOptions({"SCHEDULER": "tcp://10.0.0.1:8786"}, context).scheduler == "tcp://10.0.0.1:8786"
