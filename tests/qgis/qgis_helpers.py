"""Helpers of the QGIS tests: GeoPackage outputs and reading them back, qgis_process runs."""

import json


def recording_feedback(cancel_at=None):
    """A QgsProcessingFeedback that keeps its progress, texts, infos and warnings; cancels at ``cancel_at`` %."""
    from qgis.core import QgsProcessingFeedback

    class Recording(QgsProcessingFeedback):
        def __init__(self):
            super().__init__()
            self.progress, self.texts, self.infos, self.warnings = [], [], [], []
            self.progressChanged.connect(self._on_progress)

        def _on_progress(self, value):
            self.progress.append(value)
            if cancel_at is not None and value >= cancel_at:
                self.cancel()

        def setProgressText(self, text):  # noqa: N802
            self.texts.append(text)
            super().setProgressText(text)

        def pushInfo(self, info):  # noqa: N802
            self.infos.append(info)
            super().pushInfo(info)

        def pushWarning(self, warning):  # noqa: N802
            self.warnings.append(warning)
            super().pushWarning(warning)

    return Recording()


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
