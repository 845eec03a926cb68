"""`make package` builds a zip that installs like Plugins > Install from ZIP and runs."""
import os
import subprocess
import sys
import zipfile
from pathlib import Path

from qgis_helpers import gpkg_outputs

REPO_ROOT = Path(__file__).resolve().parents[2]


def test_the_zip_installs_into_a_fresh_profile_and_runs(district, tmp_path):
    built = subprocess.run([sys.executable, "scripts/package.py"], cwd=REPO_ROOT, capture_output=True, text=True)
    assert built.returncode == 0, built.stderr
    archive = Path(built.stdout.strip().splitlines()[-1])
    names = zipfile.ZipFile(archive).namelist()
    assert all(n.startswith("urbanvox/") for n in names)
    assert "urbanvox/metadata.txt" in names and "urbanvox/core/pipeline.py" in names
    assert not any("/tests/" in n or "/scripts/" in n or n.endswith(".pyc") for n in names)

    # What "Install from ZIP" does: unpack into the profile's python/plugins, enable it.
    profile = tmp_path / "profile"
    plugins = profile / "profiles" / "default" / "python" / "plugins"
    plugins.mkdir(parents=True)
    zipfile.ZipFile(archive).extractall(plugins)
    # qgis_process itself, without the checkout on QGIS_PLUGINPATH: only the unpacked copy exists.
    env = {k: v for k, v in os.environ.items() if k != "QGIS_PLUGINPATH"}
    env.update(QGIS_CUSTOM_CONFIG_PATH=str(profile), QT_QPA_PLATFORM="offscreen")
    binary = os.environ.get("QGIS_PROCESS") or "qgis_process.bin"

    def run(*args):
        return subprocess.run([binary, *args], env=env, capture_output=True, text=True, timeout=600)

    enabled = run("plugins", "enable", "urbanvox")
    assert enabled.returncode == 0, enabled.stdout + enabled.stderr
    listed = run("list")
    assert "urbanvox:reconstructfrompointcloud" in listed.stdout
    gpkg = tmp_path / "out.gpkg"
    outputs = [f"{k}={v}" for k, v in gpkg_outputs(gpkg).items()]
    done = run("run", "urbanvox:reconstructfrompointcloud", "--", f"INPUT={district.laz}", "VOXEL_SIZE=4",
               "SMOOTHING_ITERATIONS=0", "PROJECT=false", *outputs)
    assert done.returncode == 0, (done.stdout + done.stderr)[-3000:]
    assert gpkg.exists()
