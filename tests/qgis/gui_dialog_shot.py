"""Open each urbanvox algorithm dialog in a real QGIS GUI application and save a screenshot.

Run by test_qgis_gui.py under Xvfb: ``python gui_dialog_shot.py OUTDIR PLUGINS_DIR``.
Prints one line per dialog: algorithm id, window title, saved PNG; then one line of the
compiled kernels loaded while the dialogs were open: ``kernels:`` and their names.
"""
import os
import sys

sys.path.insert(0, sys.argv[2])  # the folder holding the urbanvox package
sys.path.insert(0, "/usr/share/qgis/python/plugins")  # processing
from qgis.core import QgsApplication  # noqa: E402

app = QgsApplication([], True)
app.initQgis()
from processing.core.Processing import Processing  # noqa: E402

Processing.initialize()
import urbanvox  # noqa: E402

plugin = urbanvox.classFactory(None)
plugin.initProcessing()
from processing.gui.AlgorithmDialog import AlgorithmDialog  # noqa: E402

out = sys.argv[1]
for alg_id in ("urbanvox:reconstructfrompointcloud", "urbanvox:reconstructfrommesh"):
    alg = QgsApplication.processingRegistry().createAlgorithmById(alg_id)
    # As the toolbox opens a dialog (processing/gui/ProcessingToolbox.py).
    dlg = alg.createCustomParametersWidget(None) or AlgorithmDialog(alg, False, None)
    dlg.resize(900, 700)
    dlg.show()
    for _ in range(20):
        app.processEvents()
    path = os.path.join(out, alg_id.split(":")[1] + ".png")
    if not dlg.grab().save(path):
        sys.exit(f"could not save {path}")
    print(f"{alg_id}\t{dlg.windowTitle()}\t{path}")
    dlg.close()
from urbanvox.core import jit  # noqa: E402

if jit._preloader is not None:
    jit._preloader.join(timeout=240)
print("kernels:", *sorted(name for name in jit.KERNELS if jit.ready(name)))
app.exitQgis()
