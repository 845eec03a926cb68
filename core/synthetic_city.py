"""A synthetic city: districts and residential tiles side by side, with exact truth.

The benchmarks' large case (:mod:`benchmarks.run`): :func:`make_city` lays
250 m tiles on one terrain plane, districts (:func:`core.synthetic.make_district`)
among residential tiles of 100 houses (:func:`make_residential`), and
:meth:`City.write_las` writes the cloud tile by tile in acquisition order,
with the memory of one tile. ``python -m core.synthetic --city OUTDIR`` (or
``python -m core.synthetic_city OUTDIR``) writes it with its truth.
"""
from __future__ import annotations

import json
import sys
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import shapely
import shapely.affinity

from .synthetic import CRS_EPSG, District, district_from_parts, las_header, make_district
from .synthetic_parts import DEFAULT_THRESHOLDS, ORIGIN, SIZE, TERRAIN, BlockTruth, Part


#: Pitch of the residential tiles' house slots (m): 10 x 10 houses per tile, at least
#: 6 m apart, and at least 3 m from the tile border so no block crosses a tile.
HOUSE_SLOT = 25.0


def _translated(b: BlockTruth, name: str, dx: float, dy: float, dz: float) -> BlockTruth:
    """A truth block moved by ``(dx, dy, dz)``: volumes and areas do not change."""
    foot = shapely.affinity.translate(shapely.from_wkt(b.footprint_wkt), dx, dy)
    return BlockTruth(name=name, volume=b.volume, footprint_area=b.footprint_area, height=b.height,
                      top_z=b.top_z + dz, ground_z=b.ground_z + dz, surface_area=b.surface_area,
                      centroid=(b.centroid[0] + dx, b.centroid[1] + dy),
                      footprint_wkt=foot.wkt, below_thresholds=b.below_thresholds,
                      on_border=b.on_border)


def make_residential(seed: int = 0) -> District:
    """A 250 m tile of 10 x 10 house slots: flat, gable and hip roofs, some with an annex.

    Same conventions as :func:`make_district` (local coordinates, terrain plane,
    corners on the 0.5 m grid, exact truth); a quarter of the houses have a lower
    flat annex touching their east wall (a two-part block with a step wall), and
    street trees stand at slot corners, clear of every roof.

    Examples
    --------
    >>> t = make_residential(0)
    >>> len(t.blocks) == 100, all(not b.on_border for b in t.blocks)
    (True, True)
    """
    rng = np.random.default_rng(seed)
    slots = int(SIZE // HOUSE_SLOT)
    room = HOUSE_SLOT - 6.0  # 3 m inset on each side
    parts = []
    for i in range(slots):
        for j in range(slots):
            L, W = rng.integers(16, 2 * int(room) + 1, 2) / 2  # 8 .. 19 m
            kx, ky = rng.integers(0, 1000, 2)
            h = rng.integers(6, 41) / 2 if rng.random() > 0.05 else rng.integers(40, 91) / 2
            kind = rng.choice(["flat", "flat", "gable", "gable", "hip"])
            rise = rng.integers(4, 10) / 2
            floor, annex = bool(rng.random() < 0.5), rng.random() < 0.25
            x0 = 3 + HOUSE_SLOT * i + (kx % (int(2 * (room - L)) + 1)) / 2
            y0 = 3 + HOUSE_SLOT * j + (ky % (int(2 * (room - W)) + 1)) / 2
            long_x = L >= W
            if kind == "hip" and L == W:
                kind = "gable"
            name = f"house_{i}_{j}"
            parts.append(Part(name, x0 + L / 2, y0 + W / 2, max(L, W), min(L, W), float(h),
                              float(rise) if kind != "flat" else 0.0, str(kind),
                              0 if long_x else 90, floor))
            free = HOUSE_SLOT * i + 3 + room - (x0 + L)  # slot room east of the house
            if annex and free >= 3.0:
                a, wa = np.floor(min(free, 6.0) * 2) / 2, np.floor(W) / 2
                parts.append(Part(name, x0 + L + a / 2, y0 + wa / 2, a, wa,
                                  float(max(3.0, np.floor(h) / 2))))
    corners = rng.choice((slots - 1) ** 2, 12, replace=False)
    trees = np.column_stack([HOUSE_SLOT * (1 + corners // (slots - 1)),
                             HOUSE_SLOT * (1 + corners % (slots - 1)),
                             rng.uniform(1.5, 2.5, len(corners)), rng.uniform(6.0, 12.0, len(corners))])
    return district_from_parts(parts, seed, trees)


@dataclass
class City:
    """Square city of 250 m tiles: districts (:func:`make_district`) among residential
    tiles (:func:`make_residential`), on one continuous terrain plane.

    Tile ``(ti, tj)`` is its generator's output moved by ``(250 ti, 250 tj)`` and
    lifted by the terrain's rise over that distance, so the terrain is the plane
    ``TERRAIN`` over the whole city and every block's truth is the tile's, translated.
    A district's ``border_cut`` block keeps its tile-clipped truth: the neighbouring
    tile has at least 3 m of bare ground along the border, and no point is written
    past it.

    Attributes
    ----------
    extent : tuple of float
        World ``(xmin, ymin, xmax, ymax)``.
    blocks : list of BlockTruth
        World coordinates; names ``"t{ti}_{tj}/{name in the tile}"``.
    tiles : list of (int, int, District)
        Tile indices and the tile in its own local coordinates.
    """

    extent: tuple[float, float, float, float]
    blocks: list[BlockTruth]
    seed: int
    tiles: list[tuple[int, int, District]] = field(default_factory=list, repr=False)

    @staticmethod
    def tile_shift(ti: int, tj: int) -> tuple[float, float, float]:
        """``(dx, dy, dz)`` from a tile's own coordinates to the city's."""
        dx, dy = SIZE * ti, SIZE * tj
        return dx, dy, TERRAIN[1] * dx + TERRAIN[2] * dy

    def write_las(self, path, *, density: float = 12.0, seed: int | None = None,
                  crs: bool = True, scan_line: float = 0.3) -> int:
        """Write the city's airborne-like cloud (LAS 1.4 / format 6; LAZ if ``.laz``).

        Tile by tile, each tile's points as :meth:`District.write_las` makes them
        and then in acquisition order (see below), appended in chunks to one file:
        memory stays that of one tile (~1 M points) whatever the city's size.

        Parameters
        ----------
        path : str or Path
        density : float
            Pulses per m2.
        seed : int, optional
            Seed of the points; tile ``n`` uses ``seed + n``; defaults to the city seed.
        crs : bool
            Write EPSG:2056 as a WKT VLR.
        scan_line : float
            Spacing (m) of the scan lines the points are ordered by: a real file is
            in acquisition order (lines swept across the flight direction), which is
            what the locality of readers and binning depends on.

        Returns
        -------
        int
            Number of points written.
        """
        import laspy

        seed = self.seed if seed is None else seed
        header = las_header(self.extent, crs)
        backend = next((b for b in (laspy.LazBackend.LazrsParallel, laspy.LazBackend.Lazrs)
                        if b.is_available()), None)
        total = 0
        with laspy.open(str(path), mode="w", header=header, laz_backend=backend) as writer:
            for n, (ti, tj, tile) in enumerate(self.tiles):
                X, Y, Z, C = tile._airborne_points(np.random.default_rng(seed + n), density)
                line = np.floor(Y / scan_line)
                # boustrophedon: odd lines swept back, like an oscillating mirror
                order = np.lexsort((np.where(line % 2 == 1, -X, X), line))
                dx, dy, dz = self.tile_shift(ti, tj)
                points = laspy.ScaleAwarePointRecord.zeros(len(order), header=header)
                points.x = X[order] + (ORIGIN[0] + dx)
                points.y = Y[order] + (ORIGIN[1] + dy)
                points.z = Z[order] + dz
                points.classification = C[order]
                points.return_number = np.ones(len(order), np.uint8)
                points.number_of_returns = np.ones(len(order), np.uint8)
                points.gps_time = (total + np.arange(len(order))) * 1e-5
                writer.write_points(points)
                total += len(order)
        return total

    def truth_table(self) -> list[dict]:
        """The blocks as JSON-ready dicts (centroid as a list)."""
        return [{**asdict(b), "centroid": list(b.centroid)} for b in self.blocks]


def make_city(size_m: float = 2000.0, seed: int = 0, district_every: int = 2) -> City:
    """A city of about ``size_m`` x ``size_m`` (rounded up to whole 250 m tiles).

    Parameters
    ----------
    size_m : float
        Side of the city (m); 2000 m gives 64 tiles, ~5,700 blocks and, at the
        default density, ~50 M points.
    seed : int
        Tile ``n`` (row-major) is generated with seed ``seed + n``.
    district_every : int
        Tiles ``(ti, tj)`` with both indices multiples of this are districts
        (special buildings, trees over roofs, 30 m boxes); the others residential.

    Examples
    --------
    >>> c = make_city(500.0)
    >>> len(c.tiles), len(c.blocks), c.extent[2] - c.extent[0]
    (4, 355, 500.0)
    """
    n_tiles = max(1, int(np.ceil(size_m / SIZE - 1e-9)))
    tiles, blocks = [], []
    for ti in range(n_tiles):
        for tj in range(n_tiles):
            n = ti * n_tiles + tj
            district = ti % district_every == 0 and tj % district_every == 0
            tile = make_district(seed + n) if district else make_residential(seed + n)
            dx, dy, dz = City.tile_shift(ti, tj)
            blocks += [_translated(b, f"t{ti}_{tj}/{b.name}", dx, dy, dz) for b in tile.blocks]
            tiles.append((ti, tj, tile))
    side = n_tiles * SIZE
    extent = (ORIGIN[0], ORIGIN[1], ORIGIN[0] + side, ORIGIN[1] + side)
    return City(extent, blocks, seed, tiles)


def main(argv: list[str] | None = None) -> int:
    """CLI: ``python -m core.synthetic_city OUTDIR [--size M] [--seed N] [--density D] [--las]``."""
    import argparse
    import time

    parser = argparse.ArgumentParser(prog="python -m core.synthetic_city")
    parser.add_argument("outdir", type=Path)
    parser.add_argument("--size", type=float, default=2000.0, help="side of the city in m (default 2000)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--density", type=float, default=12.0, help="pulses per m2 (default 12)")
    parser.add_argument("--las", action="store_true", help="uncompressed LAS instead of LAZ")
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    args.outdir.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    city = make_city(args.size, args.seed)
    built = time.perf_counter() - start
    path = args.outdir / ("city.las" if args.las else "city.laz")
    n = city.write_las(path, density=args.density)
    doc = {"crs_epsg": CRS_EPSG, "extent": list(city.extent), "seed": city.seed,
           "thresholds": DEFAULT_THRESHOLDS, "blocks": city.truth_table()}
    (args.outdir / "city_truth.json").write_text(json.dumps(doc))
    print(f"{len(city.blocks)} blocks in {len(city.tiles)} tiles ({built:.1f} s), {n} points -> {path} "
          f"({time.perf_counter() - start:.1f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
