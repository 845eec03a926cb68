"""urbanvox QGIS plugin: voxel reconstruction of building blocks (Processing provider).

QGIS imports this package and calls :func:`classFactory`. Nothing here imports
``qgis`` at module level, so ``core`` stays usable and testable without QGIS.
"""


class UrbanvoxPlugin:
    """Registers the ``urbanvox`` Processing provider (QGIS desktop and qgis_process)."""

    def __init__(self, iface):
        self.iface = iface  # None under qgis_process
        self.provider = None
        self.translator = load_translation()

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


def load_translation(locale=None):
    """Install the compiled translation of QGIS's locale (i18n/urbanvox_<lang>.qm), if there is one.

    Returns the translator (keep a reference: Qt does not own it), or None.
    """
    import os

    from qgis.core import QgsApplication
    from qgis.PyQt.QtCore import QCoreApplication, QTranslator

    language = (locale or QgsApplication.locale() or "en")[:2]
    path = os.path.join(os.path.dirname(__file__), "i18n", f"urbanvox_{language}.qm")
    if not os.path.exists(path):
        return None
    translator = QTranslator()
    if not translator.load(path):
        return None
    QCoreApplication.installTranslator(translator)
    return translator


def classFactory(iface):  # noqa: N802 (QGIS API name)
    """Return the plugin instance QGIS asks for."""
    return UrbanvoxPlugin(iface)
