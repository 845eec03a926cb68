"""Names that moved between QGIS 3.22 and QGIS 4 (Qt6), resolved once.

Each constant tries the newer spelling first (``Qgis.*`` scoped enums, QMetaType
field types) and falls back to the one QGIS 3.22 has, so the algorithms read the
same on every supported version.
"""

from qgis.core import (
    Qgis,
    QgsField,
    QgsProcessing,
    QgsProcessingParameterDefinition,
    QgsProcessingParameterFile,
    QgsProcessingParameterNumber,
    QgsWkbTypes,
)


def _first(*getters):
    for get in getters:
        try:
            return get()
        except AttributeError:
            continue
    raise AttributeError("none of the QGIS API spellings exists")


# QGIS >= 3.36 moved these enums to Qgis.*; 3.22 has them on the classes.
VECTOR_POLYGON = _first(
    lambda: Qgis.ProcessingSourceType.VectorPolygon,
    lambda: QgsProcessing.SourceType.TypeVectorPolygon,
)
NUMBER_DOUBLE = _first(
    lambda: Qgis.ProcessingNumberParameterType.Double,
    lambda: QgsProcessingParameterNumber.Type.Double,
)
NUMBER_INTEGER = _first(
    lambda: Qgis.ProcessingNumberParameterType.Integer,
    lambda: QgsProcessingParameterNumber.Type.Integer,
)
# Advanced parameters: Qgis.ProcessingParameterFlag (>= 3.36) or QgsProcessingParameterDefinition.Flag.
FLAG_ADVANCED = _first(
    lambda: Qgis.ProcessingParameterFlag.Advanced,
    lambda: QgsProcessingParameterDefinition.Flag.FlagAdvanced,
)
SOURCE_FILE = _first(
    lambda: Qgis.ProcessingSourceType.File,
    lambda: QgsProcessing.SourceType.TypeFile,
)
FILE_BEHAVIOR = _first(
    lambda: Qgis.ProcessingFileParameterBehavior.File,
    lambda: QgsProcessingParameterFile.Behavior.File,
)
# QGIS >= 3.30 has Qgis.WkbType.
MULTIPOLYGON_Z = _first(lambda: Qgis.WkbType.MultiPolygonZ, lambda: QgsWkbTypes.Type.MultiPolygonZ)
POLYGON = _first(lambda: Qgis.WkbType.Polygon, lambda: QgsWkbTypes.Type.Polygon)


def _field_types():
    # QGIS >= 3.38 takes QMetaType.Type (the only choice under Qt6); older QGIS takes QVariant.Type.
    if Qgis.versionInt() >= 33800:
        from qgis.PyQt.QtCore import QMetaType

        return {"int": QMetaType.Type.Int, "long": QMetaType.Type.LongLong, "double": QMetaType.Type.Double,
                "string": QMetaType.Type.QString}
    from qgis.PyQt.QtCore import QVariant

    return {"int": QVariant.Type.Int, "long": QVariant.Type.LongLong, "double": QVariant.Type.Double,
            "string": QVariant.Type.String}


_FIELD_TYPES = _field_types()


def make_field(name, kind):
    """A :class:`QgsField` of ``kind`` ``"int"``, ``"long"``, ``"double"`` or ``"string"``."""
    return QgsField(name, _FIELD_TYPES[kind])
