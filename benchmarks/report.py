"""The tables the benchmarks print (:mod:`benchmarks.run`): each case's stages with
their rates and peak memory, its baselines, and a summary line per case."""
from __future__ import annotations

#: The stages, in the order of the tables.
STAGES = ["read", "sample", "grid", "ground", "classify", "blocks", "eliminate", "surface", "smooth",
          "project", "measure", "buildings", "layers", "export", "export_msh", "export_msh_binary", "export_vtu",
          "preview"]
#: The issue's names for the pipeline's laps.
STAGE_NAMES = {"ground": "ground+voxelise", "eliminate": "elimination", "surface": "surfaces",
               "smooth": "smoothing", "project": "projection", "export_msh": "gmsh .msh",
               "layers": "layers", "export_msh_binary": "binary .msh", "export_vtu": ".vtu",
               "preview": "preview PNG"}
#: What a stage's rate counts.
RATE_UNIT = {"read": "read", "sample": "points", "grid": "points", "ground": "points",
             "classify": "voxels", "blocks": "voxels", "eliminate": "voxels", "surface": "voxels",
             "smooth": "faces", "project": "faces", "measure": "faces", "buildings": "read", "export": "faces",
             "layers": "faces", "export_msh": "faces", "export_msh_binary": "faces", "export_vtu": "faces",
             "preview": "faces"}
#: The summary's columns: every stage but the mesh's sampling, the grid, the measures and a
#: city model's buildings per block.
SUMMARY_STAGES = [stage for stage in STAGES if stage not in ("sample", "grid", "measure", "buildings")]


def _fmt_rate(count: float, seconds: float) -> str:
    if not seconds or seconds <= 0 or not count:
        return ""
    rate = count / seconds
    for scale, suffix in ((1e9, "G"), (1e6, "M"), (1e3, "k")):
        if rate >= scale:
            return f"{rate / scale:6.1f} {suffix}"
    return f"{rate:6.0f}  "


def _ratio(a, b) -> str:
    """``a / b`` as "12.3x", or the reason there is none."""
    if isinstance(a, str):
        return a
    if isinstance(b, str):
        return b
    return f"{a / b:.1f}x" if b else "-"


def print_case(name: str, voxel: float, r: dict) -> None:
    points = r["n_ground"] + r["n_building"]
    unit_count = {"read": r["n_read"], "points": points, "voxels": r["voxels"], "faces": r["faces"]}
    read = "points" if "sample" not in r["stages"] else "triangles"
    print(f"\n{name} @ {voxel:g} m: {r['blocks']:,} blocks, {r['n_read']:,} {read} read "
          f"({r['n_ground']:,} ground, {r['n_building']:,} building), {r['voxels']:,} voxels"
          f"{' in %d grids' % r['clusters'] if r['clusters'] > 1 else ''}, {r['faces']:,} faces; "
          f"end to end {r['e2e_s']:.2f} s, peak RSS {r['peak_rss_mb']:,.0f} MB")
    if r.get("as_qgis"):
        print("  run as QGIS runs an algorithm: on a thread of its own, glibc's default arenas (--as-qgis)")
    if "runs" in r:
        print(f"  figures of the last of {len(r['runs'])} runs in one process; end to end (method) of each: "
              + ", ".join(f"{run['e2e_s']:.2f} ({run['pipeline_s']:.2f})" for run in r["runs"]) + " s")
    if "e2e_cpu_s" in r:
        cores = r["e2e_cpu_s"] / r["e2e_s"] if r["e2e_s"] > 0 else float("nan")
        print(f"  end to end: {r['e2e_cpu_s']:.2f} s of CPU time over {r['e2e_s']:.2f} s, "
              f"{cores:.2f} cores busy on average of the machine's {r.get('cpus', '?')}")
    track = r.get("progress")
    if track:
        print(f"  progress bar: {track['updates']} updates, the longest wait {track['longest_wait_s']:.2f} s "
              f"(at \"{track['waiting_at']}\"), at most {100 * track['most_off']:.0f} % of the run off its time")
    print(f"  {'stage':<16} {'seconds':>8} {'rate':>9} {'per s':<7} {'peak RSS MB':>11}")
    for stage in STAGES:
        if stage not in r["stages"]:
            continue
        s = r["stages"][stage]
        unit = RATE_UNIT[stage]
        label = "tri" if (unit == "read" and "sample" in r["stages"]) else {"read": "pts", "points": "pts",
                                                                           "voxels": "voxels", "faces": "faces"}[unit]
        print(f"  {STAGE_NAMES.get(stage, stage):<16} {s['s']:8.2f} {_fmt_rate(unit_count[unit], s['s']):>9} "
              f"{label:<7} {s['rss']:11,.0f}")
    b = r.get("baselines")
    if not b:
        return
    bn = b["binning"]
    print(f"  {'voxelise':<16} {bn['unique_s']:8.2f} {_fmt_rate(bn['points'], bn['unique_s']):>9} pts      "
          f"(np.unique reference: a sort)")
    print(f"  {'voxelise fast':<16} {bn['fast_s']:8.3f} {_fmt_rate(bn['points'], bn['fast_s']):>9} pts      "
          "(VoxelGrid.occupied_cells, the pipeline's, inside ground; file order; "
          f"shuffled {_fmt_rate(bn['points'], bn['fast_shuffled_s']).strip()} pts/s; "
          f"same cells: {bn['equal']})")
    o3d_s = bn["open3d_s"]
    o3d_txt = o3d_s if isinstance(o3d_s, str) else (f"{o3d_s:.3f} s ({_fmt_rate(bn['points'], o3d_s).strip()} pts/s, "
                                                     f"+{bn['open3d_convert_s']:.3f} s numpy->Vector3dVector)")
    print(f"  binning vs Open3D VoxelGrid.create_from_point_cloud: {o3d_txt}; "
          f"fast is {_ratio(o3d_s, bn['fast_s'])} Open3D, {_ratio(bn['unique_s'], bn['fast_s'])} np.unique; "
          f"np.unique is {_ratio(o3d_s, bn['unique_s'])} Open3D")
    if "trimesh" in b:
        tm = b["trimesh"]
        ours = r["stages"]["sample"]["s"] + bn["fast_s"]
        tm_s = tm["trimesh_s"]
        tm_txt = tm_s if isinstance(tm_s, str) else f"{tm_s:.3f} s"
        print(f"  mesh voxelising vs trimesh mesh.voxelized(pitch): {tm_txt} vs ours (sample + fast binning) "
              f"{ours:.3f} s: ours {_ratio(tm_s, ours)} faster")
    lb = b["labelling"]
    sk = lb["skimage_s"]
    print(f"  labelling (6-conn., building mask, {lb['voxels']:,} voxels): label_blocks {lb['ours_s']:.3f} s "
          f"({_fmt_rate(lb['voxels'], lb['ours_s']).strip()} voxels/s), scipy.ndimage.label {lb['scipy_s']:.3f} s "
          f"({_ratio(lb['scipy_s'], lb['ours_s'])}), skimage.measure.label "
          f"{sk if isinstance(sk, str) else f'{sk:.3f} s'} ({_ratio(sk, lb['ours_s'])}); "
          f"mask alone {lb['mask_s']:.3f} s; same count: {lb['equal']}")
    for what, c in b["copy"].items():
        floor = c["gb_per_s"] * 1e9 / 24 if what == "points" else None
        extra = f"; binning floor (read 24 B/point once) {floor / 1e6:,.0f} M pts/s" if floor else ""
        print(f"  numpy copy of {what} ({c['bytes'] / 1e6:,.0f} MB): {c['gb_per_s']:.1f} GB/s{extra}")


def print_summary(rows: list[dict]) -> None:
    cols = SUMMARY_STAGES
    print("\nSummary (seconds; fast binning in M pts/s, ratios = baseline time / ours)")
    head = (f"{'case':<22} {'e2e':>7} " + " ".join(f"{STAGE_NAMES.get(c, c)[:9]:>9}" for c in cols)
            + f" {'RSS MB':>7} {'fastMp/s':>8} {'xO3D':>6} {'xuniq':>6} {'scipy':>6} {'skimg':>6} {'copyGB/s':>8}")
    print(head)
    for row in rows:
        r = row.get("report")
        label = f"{row['case']}@{row['voxel']:g}"
        if r is None:
            print(f"{label:<22} {row['status']}")
            continue
        cells = " ".join(f"{r['stages'][c]['s'] if c in r['stages'] else float('nan'):9.2f}" for c in cols)
        b = r.get("baselines", {})
        bn, lb, cp = b.get("binning", {}), b.get("labelling", {}), b.get("copy", {})
        extra = ""
        if bn:
            extra = (f" {bn['points'] / bn['fast_s'] / 1e6 if bn['fast_s'] else float('nan'):8.1f}"
                     f" {_ratio(bn['open3d_s'], bn['fast_s'])[:6]:>6} {_ratio(bn['unique_s'], bn['fast_s']):>6}"
                     f" {_ratio(lb['scipy_s'], lb['ours_s']):>6} {_ratio(lb['skimage_s'], lb['ours_s'])[:6]:>6}"
                     f" {cp.get('points', {}).get('gb_per_s', float('nan')):8.1f}")
        print(f"{label:<22} {r['e2e_s']:7.1f} {cells} {r['peak_rss_mb']:7.0f}{extra}")
