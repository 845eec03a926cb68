"""Print the building blocks of an urbanvox GeoPackage, beside the synthetic truth when given.

Usage::

    python scripts/show_blocks.py OUT.gpkg [--report RUN.json] [--truth truth.json]

``OUT.gpkg`` has the layers ``blocks`` and ``footprints`` written by an urbanvox algorithm;
``--report`` is the ``qgis_process --json`` output of that run (for the run summary);
``--truth`` is the ``truth.json`` of ``python -m core.synthetic``: each block is matched to the
truth block whose footprint it overlaps most (at least half of the truth footprint).
Reads the GeoPackage with sqlite3 and shapely only (no QGIS, no GDAL).
"""

import argparse
import json
import sqlite3
import struct
import sys

import shapely

#: GeoPackage geometry header: envelope size in bytes by envelope indicator (flags bits 1-3).
_ENVELOPE_BYTES = {0: 0, 1: 32, 2: 48, 3: 48, 4: 64}


def gpkg_geometry(blob):
    """The shapely geometry of a GeoPackage geometry blob."""
    if blob is None:
        return None
    magic, _version, flags = struct.unpack_from("<2sBB", blob)
    if magic != b"GP":
        raise ValueError("not a GeoPackage geometry blob")
    start = 8 + _ENVELOPE_BYTES[(flags >> 1) & 0x07]
    return shapely.from_wkb(bytes(blob[start:]))


def read_layer(path, table):
    """Rows of ``table`` as dicts, with the geometry under ``"geometry"``."""
    with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as db:
        (geom_col,) = db.execute(
            "SELECT column_name FROM gpkg_geometry_columns WHERE table_name = ?", (table,)
        ).fetchone()
        cursor = db.execute(f'SELECT * FROM "{table}" ORDER BY block_id')
        names = [d[0] for d in cursor.description]
        rows = []
        for values in cursor:
            row = dict(zip(names, values))
            row["geometry"] = gpkg_geometry(row.pop(geom_col))
            rows.append(row)
    return rows


def match_truth(footprints, truth_blocks):
    """For each footprint row, the truth block whose footprint it overlaps most (at least half of it)."""
    truth_shapes = [(t, shapely.from_wkt(t["footprint_wkt"])) for t in truth_blocks]
    matches = []
    for row in footprints:
        shape = row["geometry"]
        best, best_area = None, 0.0
        for t, truth_shape in truth_shapes:
            area = shape.intersection(truth_shape).area if shape is not None else 0.0
            if area > best_area and area >= 0.5 * truth_shape.area:
                best, best_area = t, area
        matches.append(best)
    return matches


def _fmt(value, width, digits=1):
    return f"{value:>{width}.{digits}f}" if isinstance(value, (int, float)) else f"{'-':>{width}}"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("gpkg")
    parser.add_argument("--report", help="qgis_process --json output of the run")
    parser.add_argument("--truth", help="truth.json of python -m core.synthetic")
    args = parser.parse_args(argv)

    if args.report:
        with open(args.report) as f:
            results = json.load(f).get("results", {})
        print(f"BLOCK_COUNT = {results.get('BLOCK_COUNT')}, TOTAL_VOLUME = {results.get('TOTAL_VOLUME', 0):.1f} m³")

    footprints = read_layer(args.gpkg, "footprints")
    truth = []
    if args.truth:
        with open(args.truth) as f:
            truth = json.load(f)["blocks"]
    matches = match_truth(footprints, truth) if truth else [None] * len(footprints)

    header = f"{'block':>5} {'height':>7} {'footprint':>9} {'volume':>9} {'mesh vol':>9}"
    if truth:
        header += f"   {'truth block':<18} {'height':>7} {'footprint':>9} {'volume':>9} {'vol err':>7}"
    print(header)
    print(f"{'':>5} {'m':>7} {'m²':>9} {'m³':>9} {'m³':>9}"
          + (f"   {'':<18} {'m':>7} {'m²':>9} {'m³':>9} {'%':>7}" if truth else ""))
    for row, t in zip(footprints, matches):
        line = (f"{row['block_id']:>5} {_fmt(row['height'], 7)} {_fmt(row['footprint_area'], 9)}"
                f" {_fmt(row['volume'], 9)} {_fmt(row.get('mesh_volume'), 9)}")
        if truth:
            if t is None:
                line += f"   {'(no match)':<18}"
            else:
                # The final (smoothed, projected) volume against the truth.
                value = row.get("mesh_volume") or row["volume"]
                err = 100.0 * (value - t["volume"]) / t["volume"] if t["volume"] else float("nan")
                line += (f"   {t['name']:<18} {_fmt(t['height'], 7)} {_fmt(t['footprint_area'], 9)}"
                         f" {_fmt(t['volume'], 9)} {_fmt(err, 7)}")
        print(line)
    if truth:
        expected = [t for t in truth if not t["below_thresholds"]]
        found = {t["name"] for t in matches if t is not None}
        missed = [t["name"] for t in expected if t["name"] not in found]
        print(f"{len(footprints)} blocks; {len(found)} of {len(expected)} truth blocks above the thresholds matched"
              + (f"; missed: {', '.join(missed)}" if missed else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
