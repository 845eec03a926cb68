"""``python -m core``: the method from the command line, tiles and workers included."""
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run(*args):
    return subprocess.run([sys.executable, "-m", "core", *map(str, args)], cwd=ROOT, capture_output=True,
                          text=True, timeout=600)


def test_point_cloud_in_tiles_writes_mesh_and_report(district, tmp_path):
    x0, y0, x1, y1 = district.district.extent
    report, mesh = tmp_path / "report.json", tmp_path / "district.msh"
    done = run(district.laz, "--voxel-size", 2, "--extent", x0, y0, x1, y1, "--tile-size", 100,
               "--mesh", mesh, "--binary-msh", "--report", report, "--quiet")
    assert done.returncode == 0, done.stderr
    doc = json.loads(report.read_text())
    assert doc["summary"]["block_count"] == len(doc["blocks"]) >= len(district.expected_blocks) - 3
    assert doc["stats"]["tiles"] == 9
    assert mesh.read_bytes().startswith(b"$MeshFormat\n4.1 1 8\n")  # binary
    assert f"{doc['summary']['block_count']} blocks" in done.stdout


def test_mesh_without_crs_is_refused_with_the_flag_to_use(district):
    done = run(district.stl, "--voxel-size", 2)
    assert done.returncode == 2
    assert "--crs" in done.stderr


def test_missing_file_is_an_error_not_a_traceback(tmp_path):
    done = run(tmp_path / "nothing.laz")
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
