"""QGIS fixtures: a headless QgsApplication with Processing and the urbanvox provider.

Without QGIS's Python bindings these tests are not collected, unless
``URBANVOX_REQUIRE_QGIS`` is set (``make test`` sets it): then the missing QGIS is an error,
so a CI run can never pass by silently skipping the QGIS half.

The application uses the project-local profile ``<repo>/.qgis`` (or ``URBANVOX_QGIS_PROFILE``),
as ``scripts/env.sh`` does, never the user's own. The plugin is imported as
package ``urbanvox`` through a symlink to the checkout, as QGIS imports it.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]
QGIS_PROCESS = REPO_ROOT / "scripts" / "qgis-process"

try:
    import qgis.core  # noqa: F401
except ImportError:
    if os.environ.get("URBANVOX_REQUIRE_QGIS"):
        raise
    collect_ignore_glob = ["test_*.py"]

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
# The project-local profile, as in scripts/env.sh (which the Makefile sources too).
os.environ["QGIS_CUSTOM_CONFIG_PATH"] = os.environ.get("URBANVOX_QGIS_PROFILE", str(REPO_ROOT / ".qgis"))


@pytest.fixture(scope="session")
def qgis_app():
    """The QgsApplication (no GUI) with its providers initialised."""
    from qgis.core import QgsApplication

    Path(os.environ["QGIS_CUSTOM_CONFIG_PATH"]).mkdir(parents=True, exist_ok=True)
    app = QgsApplication([], False)
    app.initQgis()
    yield app
    # No exitQgis(): tearing QGIS down at interpreter exit crashes some versions; the process ends anyway.


@pytest.fixture(scope="session")
def urbanvox_plugin(qgis_app, tmp_path_factory):
    """The plugin imported as package ``urbanvox`` and its provider registered, as QGIS does."""
    plugins = tmp_path_factory.mktemp("plugins")
    (plugins / "urbanvox").symlink_to(REPO_ROOT, target_is_directory=True)
    sys.path.insert(0, str(plugins))
    import urbanvox

    plugin = urbanvox.classFactory(None)
    plugin.initProcessing()
    yield plugin
    plugin.unload()


@pytest.fixture(scope="session")
def processing(urbanvox_plugin):
    """The ``processing`` module, initialised, with the urbanvox provider registered."""
    from qgis.core import QgsApplication

    plugins_dir = os.path.join(QgsApplication.pkgDataPath(), "python", "plugins")
    if plugins_dir not in sys.path:
        sys.path.append(plugins_dir)
    import processing
    from processing.core.Processing import Processing

    Processing.initialize()
    assert QgsApplication.processingRegistry().providerById("urbanvox") is not None
    return processing


@pytest.fixture(scope="session")
def qgis_process():
    """Run ``scripts/qgis-process ARGS`` (qgis_process.bin in the project environment).

    The plugin is enabled in the project-local profile once per session. Returns a function
    ``run(*args, timeout=...) -> CompletedProcess`` with text stdout/stderr.
    """
    def run(*args, timeout=900):
        return subprocess.run(
            [str(QGIS_PROCESS), *map(str, args)], capture_output=True, text=True, timeout=timeout, cwd=REPO_ROOT
        )

    enabled = run("plugins", "enable", "urbanvox", timeout=120)
    listed = run("plugins", timeout=120)
    if "* urbanvox" not in listed.stdout:
        pytest.fail(f"qgis_process does not load urbanvox:\n{enabled.stdout}\n{enabled.stderr}\n{listed.stdout}")
    return run
