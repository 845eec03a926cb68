"""The QGIS side of urbanvox: the Processing provider and its algorithms.

Everything that imports ``qgis`` lives here; the method itself is in ``core``.
"""

import os

ICON_PATH = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "icons", "urbanvox.svg")
