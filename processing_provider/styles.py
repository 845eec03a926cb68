"""Styles the output layers load with: blocks coloured by height in 2-D and shown
in a 3-D map view, footprints outlined, the ground in a neutral tone.

Applied through layer post-processors when QGIS loads the outputs after a run
(the Processing dialog, a model); the style functions also work on any layer.
"""

from qgis.core import (
    QgsClassificationEqualInterval,
    QgsFillSymbol,
    QgsGradientColorRamp,
    QgsGraduatedSymbolRenderer,
    QgsProcessingLayerPostProcessorInterface,
    QgsSingleSymbolRenderer,
    QgsStyle,
)
from qgis.PyQt.QtGui import QColor


def style_blocks(layer):
    """Graduated colours by ``height`` (5 classes, viridis-like) and a 3-D renderer."""
    ramp = QgsStyle.defaultStyle().colorRamp("Viridis") or QgsGradientColorRamp(QColor("#440154"), QColor("#fde725"))
    symbol = QgsFillSymbol.createSimple({"outline_style": "no"})
    renderer = QgsGraduatedSymbolRenderer("height")
    renderer.setSourceSymbol(symbol)
    renderer.setClassificationMethod(QgsClassificationEqualInterval())
    renderer.updateClasses(layer, 5)
    renderer.updateColorRamp(ramp)
    layer.setRenderer(renderer)
    _set_3d_renderer(layer, QColor("#b9b2a6"))
    layer.triggerRepaint()


def style_footprints(layer):
    """A light fill with a dark outline, readable over a base map."""
    layer.setRenderer(QgsSingleSymbolRenderer(QgsFillSymbol.createSimple(
        {"color": "255,200,120,90", "outline_color": "80,40,0,255", "outline_width": "0.4"})))
    layer.triggerRepaint()


def style_ground(layer):
    """A neutral terrain colour, also in 3-D."""
    layer.setRenderer(QgsSingleSymbolRenderer(QgsFillSymbol.createSimple(
        {"color": "200,195,180,255", "outline_style": "no"})))
    _set_3d_renderer(layer, QColor("#c8c3b4"))
    layer.triggerRepaint()


def _set_3d_renderer(layer, colour):
    """Show the polygons as they are (no extrusion) in a 3-D map view, when QGIS has 3-D."""
    try:
        from qgis._3d import QgsPhongMaterialSettings, QgsPolygon3DSymbol, QgsVectorLayer3DRenderer
    except ImportError:  # QGIS built without 3-D: the 2-D style is enough
        return
    material = QgsPhongMaterialSettings()
    material.setDiffuse(colour)
    material.setAmbient(colour.darker(200))
    symbol = QgsPolygon3DSymbol()
    symbol.setMaterial(material)
    symbol.setExtrusionHeight(0.0)
    layer.setRenderer3D(QgsVectorLayer3DRenderer(symbol))


class LayerStyler(QgsProcessingLayerPostProcessorInterface):
    """Applies a style function to an output layer once QGIS has loaded it."""

    #: Post-processors must outlive the algorithm run: QGIS holds no reference.
    _alive = []

    def __init__(self, style):
        super().__init__()
        self.style = style
        LayerStyler._alive.append(self)

    def postProcessLayer(self, layer, context, feedback):  # noqa: N802 (QGIS API name)
        self.style(layer)


def style_on_load(context, destination, style):
    """Style ``destination`` (an output id) when the run's outputs are loaded."""
    if destination and context.willLoadLayerOnCompletion(destination):
        context.layerToLoadOnCompletionDetails(destination).setPostProcessor(LayerStyler(style))
