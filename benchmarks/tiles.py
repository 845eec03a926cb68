"""Tiled runs on Dask: wall time and memory against the number of workers.

Run from the repository root with the project's venv::

    .venv/bin/python -m benchmarks.tiles                      # 2 km city, 1 m, 250 m tiles, 1 and 2 workers
    .venv/bin/python -m benchmarks.tiles --size 1000 --workers 1 2 --tile-size 250

Each run is ``python -m core CITY.laz --tile-size T --workers W`` in its own process; the peak
memory is the largest sum of resident memory over that process and its Dask workers, polled
every 0.2 s. Each run's stages (grid, ground, classify, blocks, eliminate, surface, smooth,
project, measure) are printed summed over its tiles. The synthetic city is generated once into
the benchmarks' cache folder (as ``python -m benchmarks city`` does). Block counts and total
volumes of every run are printed beside each other: they must be equal.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from .run import DENSITY, ROOT, fresh_memory_in_child, synthetic_path


def run(path: Path, voxel: float, tile: float, workers: int, report: Path) -> dict:
    """One tiled run; wall time, peak resident memory of the process tree, its report."""
    import psutil

    command = [sys.executable, "-m", "core", str(path), "--voxel-size", str(voxel), "--quiet",
               "--tile-size", str(tile), "--workers", str(workers), "--report", str(report)]
    start = time.perf_counter()
    child = subprocess.Popen(command, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    parent = psutil.Process(child.pid)
    peak = 0
    while child.poll() is None:
        try:
            tree = [parent, *parent.children(recursive=True)]
            peak = max(peak, sum(p.memory_info().rss for p in tree if p.is_running()))
        except psutil.Error:
            pass
        time.sleep(0.2)
    wall = time.perf_counter() - start
    out, err = child.communicate()
    if child.returncode != 0:
        return {"workers": workers, "failed": child.returncode, "stderr": err[-2000:]}
    doc = json.loads(report.read_text())
    timings = doc["summary"]["timings"]
    # The stages summed over the tiles (their halos and reruns included); the
    # tiled part's wall time; the reconstruction's, reading included.
    stages = {k: v for k, v in timings.items() if k != "tiles_wall"}
    return {"workers": workers, "wall_s": wall, "peak_rss_mb": peak / 2**20,
            "blocks": doc["summary"]["block_count"], "total_volume": doc["summary"]["total_volume"],
            "tiles": doc["stats"].get("tiles"), "tiles_rerun": doc["stats"].get("tiles_rerun"),
            "core_s": sum(stages.values()), "stages_s": stages,
            "tiles_wall_s": timings.get("tiles_wall"), "run_s": doc["seconds"]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.tiles", description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=float, default=2000.0, help="side of the synthetic city (m)")
    parser.add_argument("--voxel", type=float, default=1.0)
    parser.add_argument("--tile-size", type=float, default=250.0)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--density", type=float, default=DENSITY, help=f"pulses per m² (default {DENSITY:g})")
    parser.add_argument("--json", type=Path, help="write the results here")
    args = parser.parse_args(argv)
    path = synthetic_path({"kind": "city", "size": args.size, "density": args.density})
    fresh = fresh_memory_in_child()
    print(f"city {args.size:g} m ({path}), {args.voxel:g} m voxels, {args.tile_size:g} m tiles; "
          f"fresh memory {fresh:.2f} ms/MB")
    print(f"  {'workers':>7} {'wall s':>8} {'core s':>8} {'peak RSS MB':>12} {'blocks':>7} {'volume m3':>14} tiles")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for workers in args.workers:
            r = run(path, args.voxel, args.tile_size, workers, Path(tmp) / f"w{workers}.json")
            rows.append(r)
            if "failed" in r:
                print(f"  {workers:>7} failed ({r['failed']}): {r['stderr']}")
                continue
            print(f"  {workers:>7} {r['wall_s']:8.1f} {r['core_s']:8.1f} {r['peak_rss_mb']:12.0f} {r['blocks']:7d} "
                  f"{r['total_volume']:14.1f} {r['tiles']} ({r['tiles_rerun']} rerun)", flush=True)
            stages = ", ".join(f"{k} {v:.1f}" for k, v in r["stages_s"].items())
            print(f"          stages summed over the tiles (s): {stages}", flush=True)
            print(f"          the tiled part (ground level, sort by column, tiles, merge) {r['tiles_wall_s']:.1f} s "
                  f"of the reconstruction's {r['run_s']:.1f} s (the rest: reading, the clusters' test)", flush=True)
    if args.json:
        args.json.write_text(json.dumps({"size_m": args.size, "voxel": args.voxel, "tile_size": args.tile_size,
                                         "fresh_memory_ms_per_mb": fresh, "runs": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
