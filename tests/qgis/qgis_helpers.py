"""Helpers of the QGIS tests: GeoPackage outputs and reading them back, qgis_process runs."""

import json


def gpkg_sink(path, table):
    """The sink URI writing layer ``table`` of GeoPackage ``path`` (several layers per file)."""
    return f"ogr:dbname='{path}' table=\"{table}\" (geom)"


def gpkg_outputs(path):
    """OUTPUT_BLOCKS and OUTPUT_FOOTPRINTS as layers ``blocks`` and ``footprints`` of ``path``."""
    return {"OUTPUT_BLOCKS": gpkg_sink(path, "blocks"), "OUTPUT_FOOTPRINTS": gpkg_sink(path, "footprints")}


def read_layer(path, table):
    """``(layer, features)`` of ``table`` in GeoPackage ``path``, checked valid."""
    from qgis.core import QgsVectorLayer

    layer = QgsVectorLayer(f"{path}|layername={table}", table, "ogr")
    assert layer.isValid(), f"cannot open {table} in {path}"
    return layer, list(layer.getFeatures())


def run_json(qgis_process, algorithm, **parameters):
    """``qgis_process --json run ALGORITHM -- K=V ...``: (CompletedProcess, parsed JSON or None)."""
    proc = qgis_process("--json", "run", algorithm, "--", *(f"{k}={v}" for k, v in parameters.items()))
    try:
        report = json.loads(proc.stdout)
    except json.JSONDecodeError:
        report = None
    return proc, report
