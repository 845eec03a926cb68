"""Command line: the method without QGIS, for scripts, clusters and benchmarks.

``python -m core INPUT [INPUT ...] [options]`` reconstructs LAS/LAZ files (a
tile collection is one cloud) or one building mesh (STL/OBJ/PLY/OFF), writes
the conforming mesh and a JSON report of the blocks, and prints a summary.
Tiles and Dask workers are chosen with ``--tile-size``, ``--workers`` and
``--scheduler`` (:mod:`core.tiles`).

Examples
--------
.. code-block:: console

    $ python -m core tiles/*.laz --voxel-size 1 --tile-size 250 --workers 2 \\
          --mesh city.msh --report city.json
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from .errors import Cancelled, UrbanvoxError
from .export import check_output_path
from .heap import one_arena
from .pipeline import ReconstructionParams, reconstruct_mesh, reconstruct_point_cloud
from .readers.cityjson import is_cityjson
from .tiles import TileOptions

POINT_CLOUD_SUFFIXES = (".las", ".laz")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m core", description=__doc__.split("\n\n")[0])
    p.add_argument("inputs", nargs="+", type=Path, help="LAS/LAZ files, or one building mesh or CityJSON file")
    p.add_argument("--crs", help="CRS of the data (required when the file has none, e.g. EPSG:28992)")
    p.add_argument("--voxel-size", type=float, default=1.0, help="voxel edge in metres (default 1)")
    p.add_argument("--ground-classes", default="2", help="LAS ground class codes (default 2)")
    p.add_argument("--building-classes", default="6", help="LAS building class codes (default 6)")
    p.add_argument("--ground-mesh", type=Path, help="terrain mesh (or CityJSON terrain) for a mesh input")
    p.add_argument("--lod", help="CityJSON input: the level of detail to take where an object has it "
                                 "(e.g. 1.2; default: each object's highest)")
    p.add_argument("--fill-under-roofs", action="store_true",
                   help="mesh input: every column solid up to its roof (for models with missing walls)")
    p.add_argument("--extent", type=float, nargs=4, metavar=("XMIN", "YMIN", "XMAX", "YMAX"),
                   help="domain extent in the data's CRS")
    p.add_argument("--smoothing", type=int, default=3, help="Catmull-Clark passes (default 3)")
    p.add_argument("--no-projection", action="store_true", help="do not project nodes onto the data")
    p.add_argument("--tile-size", type=float, default=0.0,
                   help="tiles of this side in metres, reconstructed separately and merged (0: one grid)")
    p.add_argument("--workers", type=int, default=0,
                   help="worker processes for the tiles on a local Dask cluster (0 or 1: in this process; "
                        "without --tile-size, tiles of 250 m)")
    p.add_argument("--scheduler", help="address of a Dask scheduler for the tiles (tcp://host:8786)")
    p.add_argument("--mesh", type=Path, help="write the conforming mesh (.msh .vtu .obj .stl .ply)")
    p.add_argument("--binary-msh", action="store_true",
                   help="write a .msh mesh in gmsh's binary encoding (faster on large areas, exact coordinates)")
    p.add_argument("--report", type=Path, help="write the blocks and the run's figures as JSON")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    return p


def tile_options(args: argparse.Namespace) -> TileOptions | None:
    """``--tile-size``, ``--workers`` and ``--scheduler`` as tiles, or None
    for one grid. Workers or a scheduler without a tile size mean tiles of
    the core's default size, as in the Processing algorithms: several
    processes need several tiles. A bad value is refused by :class:`TileOptions`.

    Examples
    --------
    >>> tile_options(build_parser().parse_args(["city.laz", "--workers", "2"]))
    TileOptions(tile_size=250.0, halo=10.0, workers=2, scheduler=None)
    >>> tile_options(build_parser().parse_args(["city.laz", "--workers", "1"])) is None
    True
    """
    if args.tile_size == 0 and args.workers in (0, 1) and not args.scheduler:
        return None
    return TileOptions(tile_size=args.tile_size or TileOptions.tile_size, workers=args.workers,
                       scheduler=args.scheduler)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    one_arena()  # this process is the run's: its threads share the heap that reuses freed memory
    last = [-1]

    def progress(fraction: float, message: str) -> None:
        if not args.quiet and int(fraction * 20) != last[0]:
            last[0] = int(fraction * 20)
            print(f"{100 * fraction:5.1f} % {message}", file=sys.stderr, flush=True)

    start = time.perf_counter()
    try:
        params = ReconstructionParams(voxel_size=args.voxel_size, smoothing_iterations=args.smoothing,
                                      project=not args.no_projection,
                                      extent=tuple(args.extent) if args.extent else None)
        tiles = tile_options(args)
        # The outputs' paths before the run, not after its minutes of work.
        if args.mesh:
            check_output_path(args.mesh)
        if args.report:
            check_output_path(args.report, suffixes=None)
        if all(p.suffix.lower() in POINT_CLOUD_SUFFIXES for p in args.inputs):
            result = reconstruct_point_cloud(args.inputs, crs=args.crs, ground_classes=args.ground_classes,
                                             building_classes=args.building_classes, params=params,
                                             tiles=tiles, progress=progress)
        elif len(args.inputs) == 1:
            if not args.crs and not is_cityjson(args.inputs[0]):
                raise UrbanvoxError("A mesh carries no CRS: give it with --crs (e.g. --crs EPSG:2056).")
            result = reconstruct_mesh(args.inputs[0], crs=args.crs, ground_path=args.ground_mesh,
                                      params=params, fill_under_roofs=args.fill_under_roofs, lod=args.lod,
                                      tiles=tiles, progress=progress)
        else:
            raise UrbanvoxError("Give LAS/LAZ files, or a single building mesh.")
        if args.mesh:
            result.write_mesh(args.mesh, binary=args.binary_msh)
    except Cancelled:
        print("cancelled", file=sys.stderr)
        return 130
    except UrbanvoxError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except OSError as error:  # a disk full, a folder removed meanwhile: no traceback
        print(f"error: cannot write {error.filename or 'the output'}: {error.strerror or error}", file=sys.stderr)
        return 2
    seconds = time.perf_counter() - start
    for warning in result.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    summary = result.summary
    print(f"{summary['block_count']} blocks, {summary['total_volume']:.1f} m³, "
          f"grid {' x '.join(map(str, summary['grid_shape']))}, {seconds:.1f} s")
    if args.report:
        report = {"summary": summary, "seconds": seconds, "stats": _plain(result.stats),
                  "warnings": result.warnings, "blocks": result.block_rows()}
        try:
            args.report.write_text(json.dumps(report, indent=1))
        except OSError as error:
            print(f"error: cannot write the report {args.report}: {error.strerror or error}", file=sys.stderr)
            return 2
    return 0


def _plain(value):
    """JSON-able copy (numpy numbers to Python numbers)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if hasattr(value, "item"):
        return value.item()
    return value
