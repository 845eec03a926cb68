"""The algorithm dialogs build in a real QGIS GUI (under Xvfb); screenshots are kept in
``test-artifacts/`` at the repository root."""
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = REPO_ROOT / "test-artifacts"


@pytest.fixture
def display():
    if shutil.which("Xvfb") is None:
        if os.environ.get("URBANVOX_REQUIRE_QGIS"):
            pytest.fail("Xvfb is missing: make setup installs it (package xvfb)")
        pytest.skip("Xvfb not installed")
    for number in range(90, 110):
        if not Path(f"/tmp/.X11-unix/X{number}").exists() and not Path(f"/tmp/.X{number}-lock").exists():
            break
    server = subprocess.Popen(["Xvfb", f":{number}", "-screen", "0", "1280x1024x24", "-nolisten", "tcp"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    for _ in range(50):
        if Path(f"/tmp/.X11-unix/X{number}").exists():
            break
        time.sleep(0.1)
    yield f":{number}"
    server.terminate()
    server.wait(timeout=10)


def test_algorithm_dialogs_open_are_captured_and_load_the_kernels(display, urbanvox_plugin):
    ARTIFACTS.mkdir(exist_ok=True)
    plugins = REPO_ROOT / ".build" / "plugins"  # holds the urbanvox symlink (scripts/env.sh)
    plugins.mkdir(parents=True, exist_ok=True)
    link = plugins / "urbanvox"
    if not link.exists():
        link.symlink_to(REPO_ROOT, target_is_directory=True)
    env = {**os.environ, "DISPLAY": display, "QT_QPA_PLATFORM": "xcb"}
    run = subprocess.run([sys.executable, str(Path(__file__).with_name("gui_dialog_shot.py")), str(ARTIFACTS),
                          str(plugins)], env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-3000:]
    shots = [line.split("\t") for line in run.stdout.splitlines() if line.startswith("urbanvox:")]
    assert [s[1] for s in shots] == ["Reconstruct building blocks from point cloud",
                                     "Reconstruct building blocks from mesh"]
    for _, _, path in shots:
        png = Path(path)
        assert png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size > 20_000
    # Opening a dialog loaded the compiled kernels meanwhile: the session's first run does not wait.
    loaded = next(line.split()[1:] for line in run.stdout.splitlines() if line.startswith("kernels:"))
    from core import jit

    assert loaded == sorted(jit.KERNELS)
