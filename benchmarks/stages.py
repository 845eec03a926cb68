"""Per-stage wall time and peak memory of the whole method on real and synthetic data.

Not a test: prints a table. Run from the repository root with the project's venv::

    .venv/bin/python -m benchmarks.stages            # all cases
    .venv/bin/python -m benchmarks.stages delft      # some of them

Cases: the Delft AHN3 strip and the six Montpellier tiles (from ../shared/data, skipped when
absent), the Zurich LoD2 STL, and the synthetic district as LAZ, each at 1 m and 0.5 m voxels.
Each case runs in a fresh process so that the peak RSS is its own.
"""
from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"

CASES = {
    "delft": ("las", [DATA / "delft_ahn3/ahn3_cropped_2.laz"], "EPSG:28992"),
    "montpellier": ("las", sorted((DATA / "montpellier_ign").glob("*.laz")), None),
    "zurich": ("mesh", [DATA / "cityjson/zurich_subset_lod2_buildings.stl"], "EPSG:2056"),
    "district": ("las", None, None),  # generated
}


def run_case(kind: str, paths: list[str], crs: str | None, voxel: float) -> dict:
    """One reconstruction (in this process); stage timings, peak RSS, counts."""
    from core.pipeline import ReconstructionParams, reconstruct_mesh, reconstruct_point_cloud

    params = ReconstructionParams(voxel_size=voxel)
    start = time.perf_counter()
    if kind == "las":
        result = reconstruct_point_cloud(paths, crs=crs, params=params)
    else:
        result = reconstruct_mesh(paths[0], crs=crs, params=params)
    total = time.perf_counter() - start
    return {"total": total, "timings": result.timings, "peak_rss_mb": result.stats.get("peak_rss_mb", {}),
            "points": result.stats.get("n_points", {}), "voxels": result.stats.get("n_voxels"),
            "faces": result.stats.get("n_faces"), "blocks": len(result.blocks)}


def main(argv: list[str]) -> int:
    if argv and argv[0] == "--child":
        kind, paths, crs, voxel = json.loads(argv[1])
        print(json.dumps(run_case(kind, paths, crs, voxel)))
        return 0
    wanted = argv or list(CASES)
    with tempfile.TemporaryDirectory() as tmp:
        for name in wanted:
            kind, paths, crs = CASES[name]
            if paths is None:
                from core.synthetic import make_district
                paths = [Path(tmp) / "district.laz"]
                make_district(0).write_las(paths[0])
            if not paths or not all(Path(p).exists() for p in paths):
                print(f"{name}: data not found, skipped")
                continue
            for voxel in (1.0, 0.5):
                job = json.dumps([kind, [str(p) for p in paths], crs, voxel])
                out = subprocess.run([sys.executable, "-m", "benchmarks.stages", "--child", job], cwd=ROOT,
                                     capture_output=True, text=True)
                if out.returncode != 0:
                    print(f"{name} @ {voxel} m: failed\n{out.stderr[-2000:]}")
                    continue
                report = json.loads(out.stdout.strip().splitlines()[-1])
                points = sum(report["points"].values())
                print(f"\n{name} @ {voxel} m: {report['blocks']} blocks, {points:,} points, "
                      f"{report['voxels']:,} voxels, {report['faces']:,} faces, total {report['total']:.2f} s")
                print(f"  {'stage':<10} {'seconds':>8} {'peak RSS MB':>12}")
                for stage, seconds in report["timings"].items():
                    print(f"  {stage:<10} {seconds:8.2f} {report['peak_rss_mb'].get(stage, float('nan')):12.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
