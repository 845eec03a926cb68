"""The plugin through ``qgis_process`` (scripts/qgis-process), as users and the demo run it.

These also catch what in-process tests cannot: the qgis_process executable links QGIS's GEOS
and PROJ into the global symbol scope, so Python wheels that bundle their own copies (shapely)
end up calling QGIS's versions there.
"""

import os
import shutil
import sqlite3
import subprocess
from pathlib import Path

import pytest
from qgis_helpers import gpkg_outputs, run_json

REPO_ROOT = Path(__file__).resolve().parents[2]
VOXEL = 2.0  # a coarser grid keeps these subprocess runs short


def gpkg_counts(path):
    with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as db:
        tables = [row[0] for row in db.execute("SELECT table_name FROM gpkg_contents ORDER BY table_name")]
        return {t: db.execute(f'SELECT count(*) FROM "{t}"').fetchone()[0] for t in tables}


def test_list_shows_both_algorithms(qgis_process):
    proc = qgis_process("list")
    assert proc.returncode == 0, proc.stderr
    assert "urbanvox:reconstructfrompointcloud" in proc.stdout
    assert "urbanvox:reconstructfrommesh" in proc.stdout


@pytest.mark.parametrize("alg", ["reconstructfrompointcloud", "reconstructfrommesh"])
def test_help_describes_the_parameters(qgis_process, alg):
    proc = qgis_process("help", f"urbanvox:{alg}")
    assert proc.returncode == 0, proc.stderr
    for name in ("INPUT", "CRS", "VOXEL_SIZE", "MIN_HEIGHT", "OUTPUT_BLOCKS", "OUTPUT_FOOTPRINTS", "BLOCK_COUNT"):
        assert name in proc.stdout


def test_run_point_cloud_json_writes_the_geopackage_and_a_binary_msh(qgis_process, district, tmp_path):
    gpkg = tmp_path / "pointcloud.gpkg"
    mesh = tmp_path / "district.msh"
    proc, report = run_json(
        qgis_process, "urbanvox:reconstructfrompointcloud", INPUT=district.laz, VOXEL_SIZE=VOXEL,
        OUTPUT_MESH=mesh, MESH_BINARY="true", **gpkg_outputs(gpkg)
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    count = report["results"]["BLOCK_COUNT"]
    assert count > 0 and report["results"]["TOTAL_VOLUME"] > 0
    assert gpkg_counts(gpkg) == {"blocks": count, "footprints": count}
    content = mesh.read_bytes()
    assert content.startswith(b"$MeshFormat\n4.1 1 8\n") and content.endswith(b"$EndElements\n")
    names = content.split(b"$PhysicalNames\n")[1].split(b"$EndPhysicalNames")[0].decode().splitlines()[1:]
    assert sum(name.startswith("3 ") for name in names) == count + 2  # a volume per block, the ground, the air


def test_run_mesh_json_writes_the_geopackage(qgis_process, district, tmp_path):
    gpkg = tmp_path / "mesh.gpkg"
    proc, report = run_json(
        qgis_process,
        "urbanvox:reconstructfrommesh",
        INPUT=district.stl,
        GROUND=district.ground_stl,
        CRS=district.crs,
        VOXEL_SIZE=VOXEL,
        **gpkg_outputs(gpkg),
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    count = report["results"]["BLOCK_COUNT"]
    assert count > 0
    assert gpkg_counts(gpkg) == {"blocks": count, "footprints": count}


def test_missing_crs_fails_with_a_clear_message_and_writes_nothing(qgis_process, district, tmp_path):
    las = tmp_path / "no_crs.las"
    district.district.write_las(las, density=0.5, crs=False)
    gpkg = tmp_path / "out.gpkg"
    proc, _ = run_json(qgis_process, "urbanvox:reconstructfrompointcloud", INPUT=las, **gpkg_outputs(gpkg))
    assert proc.returncode != 0
    output = proc.stdout + proc.stderr
    assert "CRS" in output and "Traceback" not in output
    assert not gpkg.exists()


def test_without_the_dependencies_the_provider_loads_and_runs_name_the_pip_command(qgis_process, district, tmp_path):
    """qgis_process with the project's profile and plugin path but not the venv: no shapely, laspy, trimesh."""
    binary = os.environ.get("QGIS_PROCESS") or shutil.which("qgis_process.bin")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(  # as scripts/env.sh, which the qgis_process fixture has run, minus the venv
        QT_QPA_PLATFORM="offscreen",
        QGIS_CUSTOM_CONFIG_PATH=os.environ.get("URBANVOX_QGIS_PROFILE", str(REPO_ROOT / ".qgis")),
        QGIS_PLUGINPATH=str(REPO_ROOT / ".build" / "plugins"),
    )

    def run(*args):
        return subprocess.run([binary, *map(str, args)], capture_output=True, text=True, env=env, timeout=300)

    assert "urbanvox:reconstructfrompointcloud" in run("list").stdout
    gpkg = tmp_path / "out.gpkg"
    proc = run("run", "urbanvox:reconstructfrompointcloud", "--", f"INPUT={district.laz}",
               *(f"{name}={value}" for name, value in gpkg_outputs(gpkg).items()))
    output = proc.stdout + proc.stderr
    assert proc.returncode != 0
    assert "pip install" in output and "laspy" in output, output[-3000:]
    assert not gpkg.exists()


def write_las(path, xyz, classes, crs=None):
    import laspy
    import numpy as np

    header = laspy.LasHeader(point_format=6, version="1.4")
    header.offsets = np.floor(xyz.min(axis=0)) if len(xyz) else np.zeros(3)
    header.scales = np.array([0.001, 0.001, 0.001])
    if crs:
        import pyproj
        header.add_crs(pyproj.CRS.from_user_input(crs))
    las = laspy.LasData(header)
    las.x, las.y, las.z = xyz.T if len(xyz) else (np.zeros(0),) * 3
    las.classification = classes
    las.write(path)


def bad_inputs(tmp_path):
    import numpy as np

    rng = np.random.default_rng(0)
    xyz = np.column_stack([rng.uniform(0, 50, 2000) + 2_600_000, rng.uniform(0, 50, 2000) + 1_200_000,
                           rng.uniform(400, 410, 2000)])
    empty = tmp_path / "empty.las"
    write_las(empty, np.zeros((0, 3)), np.zeros(0, np.uint8), crs="EPSG:2056")
    no_ground = tmp_path / "no_ground.las"
    write_las(no_ground, xyz, np.full(2000, 6, np.uint8), crs="EPSG:2056")
    geographic = tmp_path / "geographic.las"
    write_las(geographic, xyz - [2_600_000 - 6, 1_200_000 - 46, 0], np.full(2000, 2, np.uint8), crs="EPSG:4326")
    return {"empty": (empty, "no points"), "no_ground": (no_ground, "GROUND_CLASSES"),
            "geographic": (geographic, "geographic")}


@pytest.mark.parametrize("case", ["empty", "no_ground", "geographic"])
def test_bad_input_fails_with_a_clear_message_and_writes_nothing(qgis_process, tmp_path, case):
    path, expected = bad_inputs(tmp_path)[case]
    gpkg = tmp_path / "out.gpkg"
    mesh = tmp_path / "out.msh"
    proc, _ = run_json(qgis_process, "urbanvox:reconstructfrompointcloud", INPUT=path, OUTPUT_MESH=mesh,
                       **gpkg_outputs(gpkg))
    output = proc.stdout + proc.stderr
    assert proc.returncode != 0
    assert expected.lower() in output.lower() and "Traceback" not in output, output[-2000:]
    assert not gpkg.exists() and not mesh.exists()
