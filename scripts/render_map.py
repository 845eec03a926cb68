"""Render a result as QGIS draws it (2-D map canvas, the plugin's own styles) to a PNG.

    .venv/bin/python scripts/render_map.py demo-output/pointcloud.gpkg docs/qgis_map.png

Layers ``ground``, ``footprints`` and ``blocks`` of the GeoPackage, styled by
processing_provider/styles.py, rendered with QgsMapRendererParallelJob (no display needed).
"""
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / ".build" / "plugins"))


def main(gpkg: str, png: str) -> int:
    from qgis.core import QgsApplication, QgsMapRendererParallelJob, QgsMapSettings, QgsVectorLayer
    from qgis.PyQt.QtCore import QSize
    from qgis.PyQt.QtGui import QColor

    app = QgsApplication([], False)
    app.initQgis()
    from urbanvox.processing_provider.styles import style_blocks, style_footprints, style_ground

    layers = []
    for table, style in (("blocks", style_blocks), ("footprints", style_footprints), ("ground", style_ground)):
        layer = QgsVectorLayer(f"{gpkg}|layername={table}", table, "ogr")
        if layer.isValid():
            style(layer)
            layers.append(layer)
    settings = QgsMapSettings()
    settings.setLayers(layers)  # first on top
    settings.setDestinationCrs(layers[0].crs())
    settings.setExtent(layers[-1].extent().buffered(5))
    settings.setOutputSize(QSize(1000, 1000))
    settings.setBackgroundColor(QColor("white"))
    job = QgsMapRendererParallelJob(settings)
    job.start()
    job.waitForFinished()
    job.renderedImage().save(png)
    app.exitQgis()
    print(png)
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
