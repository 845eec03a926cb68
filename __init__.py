"""urbanvox QGIS plugin: voxel reconstruction of building blocks (Processing provider).

QGIS imports this package and calls :func:`classFactory`. Nothing here imports
``qgis`` at module level, so ``core`` stays usable and testable without QGIS.
"""


class UrbanvoxPlugin:
    """Registers the ``urbanvox`` Processing provider (QGIS desktop and qgis_process)."""

    def __init__(self, iface):
        self.iface = iface  # None under qgis_process
        self.provider = None

    def initProcessing(self):  # noqa: N802 (QGIS API name)
        """Called by qgis_process (``hasProcessingProvider=yes``) and by :meth:`initGui`."""
        if self.provider is not None:
            return
        from qgis.core import QgsApplication

        from .processing_provider.provider import UrbanvoxProvider

        self.provider = UrbanvoxProvider()
        QgsApplication.processingRegistry().addProvider(self.provider)

    def initGui(self):  # noqa: N802 (QGIS API name)
        self.initProcessing()

    def unload(self):
        if self.provider is None:
            return
        from qgis.core import QgsApplication

        QgsApplication.processingRegistry().removeProvider(self.provider)
        self.provider = None


def classFactory(iface):  # noqa: N802 (QGIS API name)
    """Return the plugin instance QGIS asks for."""
    return UrbanvoxPlugin(iface)
