"""The ``urbanvox`` Processing provider."""

from qgis.core import QgsProcessingProvider
from qgis.PyQt.QtCore import QCoreApplication
from qgis.PyQt.QtGui import QIcon

from . import ICON_PATH
from .algorithms.reconstruct_mesh import ReconstructFromMesh
from .algorithms.reconstruct_point_cloud import ReconstructFromPointCloud


def tr(text):
    """Translate in the plugin's one context (see i18n/)."""
    return QCoreApplication.translate("urbanvox", text)


class UrbanvoxProvider(QgsProcessingProvider):
    """Building blocks from point clouds and meshes, by voxels."""

    def id(self):
        return "urbanvox"

    def name(self):
        return "urbanvox"

    def longName(self):  # noqa: N802 (QGIS API name)
        return tr("urbanvox: voxel building blocks from point clouds and meshes")

    def icon(self):
        return QIcon(ICON_PATH)

    def svgIconPath(self):  # noqa: N802 (QGIS API name)
        return ICON_PATH

    def loadAlgorithms(self):  # noqa: N802 (QGIS API name)
        self.addAlgorithm(ReconstructFromPointCloud())
        self.addAlgorithm(ReconstructFromMesh())
