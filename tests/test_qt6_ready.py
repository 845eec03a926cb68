"""QGIS 4 (Qt6) readiness of the QGIS side, checked on the source text.

Qt6 removed unscoped enum access (``QVariant.Int``) and PyQt5-only imports; QGIS
provides ``qgis.PyQt`` as the one import path for both Qt versions.
"""
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCES = sorted([ROOT / "__init__.py", *(ROOT / "processing_provider").rglob("*.py")])

# Enum values reached straight from a class, without their enum's name, e.g.
# QgsProcessing.TypeVectorPolygon, QVariant.Int, Qt.AlignLeft, QgsWkbTypes.MultiPolygonZ.
UNSCOPED = re.compile(
    r"\b(QVariant|Qt|QgsProcessing|QgsWkbTypes|QgsProcessingParameterNumber|QgsProcessingParameterFile|"
    r"QgsProcessingParameterDefinition|QgsFeatureSink)\.(?!Type\b|SourceType\b|Flag\b|Behavior\b|"
    r"GeometryType\b|AlignmentFlag\b|[a-z_])[A-Z]\w*")


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_only_qgis_pyqt_imports_and_scoped_enums(path):
    text = path.read_text(encoding="utf-8")
    assert not re.search(r"^\s*(from|import)\s+PyQt[56]\b", text, re.M), "import Qt via qgis.PyQt"
    code = "\n".join(line.split("#")[0] for line in text.splitlines())
    found = UNSCOPED.findall(code)
    assert not found, f"unscoped enums in {path.name}: {found}"


def test_the_lint_catches_what_it_should():
    assert UNSCOPED.search("x = QVariant.Int")
    assert UNSCOPED.search("t = QgsProcessing.TypeVectorPolygon")
    assert not UNSCOPED.search("t = QgsProcessing.SourceType.TypeVectorPolygon")
    assert not UNSCOPED.search("f = QgsFeatureSink.Flag.FastInsert")
