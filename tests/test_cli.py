"""``python -m core``: the method from the command line, tiles and workers included."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

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


def test_workers_or_a_scheduler_alone_mean_tiles_of_the_default_size():
    # As the Processing algorithms take WORKERS and SCHEDULER: several processes need several tiles.
    from core.cli import build_parser, tile_options
    from core.errors import UrbanvoxError
    from core.tiles import TileOptions

    def tiles(*flags):
        return tile_options(build_parser().parse_args(["city.laz", *flags]))

    assert tiles() is None and tiles("--workers", "1") is None
    assert tiles("--workers", "3") == TileOptions(250.0, workers=3)
    assert tiles("--scheduler", "tcp://host:8786") == TileOptions(250.0, scheduler="tcp://host:8786")
    assert tiles("--tile-size", "100", "--workers", "2") == TileOptions(100.0, workers=2)
    with pytest.raises(UrbanvoxError, match="number of workers"):
        tiles("--workers", "-1")


def test_mesh_without_crs_is_refused_with_the_flag_to_use(district):
    done = run(district.stl, "--voxel-size", 2)
    assert done.returncode == 2
    assert "--crs" in done.stderr


def test_a_cityjson_house_without_two_walls_is_filled_with_the_flag(tmp_path):
    """A 20 x 10 m house in CityJSON (CRS in the file), its floor at 0 on a terrain at -1.2 m and
    its roof at 9 m, that lacks two of its walls: the air fills it, and the run says so;
    --fill-under-roofs gives its volume from the terrain to the roof."""
    corners = [[0, 0, 0], [20, 0, 0], [20, 10, 0], [0, 10, 0], [0, 0, 9], [20, 0, 9], [20, 10, 9], [0, 10, 9],
               [-10, -10, -1.2], [30, -10, -1.2], [30, 20, -1.2], [-10, 20, -1.2]]
    floor, roof, south, north = [[0, 3, 2, 1]], [[4, 5, 6, 7]], [[0, 1, 5, 4]], [[2, 3, 7, 6]]
    house = {"type": "CityJSON", "version": "2.0", "vertices": [[x + 5e5, y + 5e6, z] for x, y, z in corners],
             "metadata": {"referenceSystem": "https://www.opengis.net/def/crs/EPSG/0/32631"},
             "CityObjects": {
                 "house": {"type": "Building", "geometry": [
                     {"type": "MultiSurface", "lod": "2.2", "boundaries": [floor, roof, south, north]}]},
                 "terrain": {"type": "TINRelief", "geometry": [
                     {"type": "CompositeSurface", "lod": "1", "boundaries": [[[8, 9, 10]], [[8, 10, 11]]]}]}}}
    path = tmp_path / "house.city.json"
    path.write_text(json.dumps(house))
    volumes = {}
    for flags in ((), ("--fill-under-roofs",)):
        report = tmp_path / "report.json"
        done = run(path, "--voxel-size", 0.5, "--report", report, "--quiet", *flags)
        assert done.returncode == 0, done.stderr
        volumes[flags] = sum(block["mesh_volume"] for block in json.loads(report.read_text())["blocks"])
        assert ("air under a roof" in done.stderr) == (not flags), done.stderr
    assert volumes[()] < 0.5 * 20 * 10 * 10.2  # nothing left of it, here
    assert volumes[("--fill-under-roofs",)] == pytest.approx(20 * 10 * 10.2, rel=0.02)


def test_missing_file_is_an_error_not_a_traceback(tmp_path):
    done = run(tmp_path / "nothing.laz")
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr


_NUMBERS = ("--smoothing", "--workers", "--tile-size")


@pytest.mark.parametrize("flag, name, says", [
    ("--mesh", "missing/city.msh", "does not exist"),
    ("--mesh", "city.txt", "Unknown mesh format '.txt'"),
    ("--mesh", "folder", "Unknown mesh format"),
    ("--report", "missing/report.json", "does not exist"),
    ("--report", "folder", "is a folder"),
    ("--smoothing", "-1", "smoothing passes"),
    ("--workers", "-1", "number of workers must be a whole number, 0 or 1"),
    ("--tile-size", "-5", "tile size must be a positive number"),
])
def test_outputs_that_cannot_be_written_stop_the_run_before_it_starts(district, tmp_path, flag, name, says):
    """A bad output path is an error at once (not after the run), without a traceback, and writes nothing."""
    (tmp_path / "folder").mkdir()
    done = run(district.laz, "--voxel-size", 2, flag, name if flag in _NUMBERS else tmp_path / name, "--quiet")
    assert done.returncode == 2 and says in done.stderr and "Traceback" not in done.stderr
    assert "blocks," not in done.stdout  # no run
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder"] and not any((tmp_path / "folder").iterdir())
