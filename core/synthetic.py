"""Synthetic city district with exact, analytic truth: the embedded default dataset.

The district is a 250 m x 250 m square in Swiss LV95 (EPSG:2056) whose south-west
corner is ``ORIGIN = (2_600_000, 1_200_000)``. Coordinates are deliberately large:
float32 has a 0.25 m step at x = 2.6e6, so code that drops to float32 too early
shows it. Every axis-aligned corner lies on a 0.5 m grid and is therefore exact in
the float32 STL; the ``rotated45`` corners are not (up to 0.125 m off, as in real data).

Terrain is the plane ``z = 400 + 0.02 * (x - x0) + 0.01 * (y - y0)``.
Each building *part* is a rectangle (possibly rotated) with a flat, gable or hip roof
whose eave is at the absolute height ``terrain(part centre) + h``.

Truth
-----
See :mod:`core.synthetic_parts`: every block's volume, footprint, heights and
surface are exact (:class:`~core.synthetic_parts.BlockTruth`).

LAS content (LAS 1.4, point format 6, for both ``.las`` and ``.laz``)
---------------------------------------------------------------------
class 2 ground: terrain where no roof (also in the courtyard and, partly, under
free-standing trees; never under a roof); class 6 building: roof points at
``density`` plus facade points at 0.5 pt/m2 of wall; class 5 vegetation: tree crowns,
two of which overhang roofs (the roof has a hole there); class 7: 36 noise points far
above or below; the four extent corners are class-2 points so the header bounds
equal the extent. z has N(0, 2.5 cm) noise. Trees are *not* blocks in the truth:
a pipeline must drop class 5 (and 7) points.

STL content (binary, float32, world coordinates, like 3dfier / CityGML exports)
-------------------------------------------------------------------------------
Buildings only, one shell per part: walls from 0.2 m below the part's lowest terrain
corner up to the roof. Parts with ``floor=False`` have open bottoms; the three
``intersecting_boxes`` parts overlap (inner faces), courtyard wings and row houses
touch (coincident faces); some parts have inverted or mixed winding. ``border_cut``
is not clipped: its mesh runs 12 m past the extent, its truth is the inside part.
The terrain is a separate STL (:meth:`District.write_ground_stl`).

Example
-------
>>> d = make_district()
>>> len(d.blocks) >= 30
True
>>> b = next(b for b in d.blocks if b.name == "tower")
>>> round(b.volume, 6), round(b.footprint_area, 6)
(8640.0, 144.0)
"""

from __future__ import annotations

import datetime
import json
import sys
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import shapely
from shapely.geometry import Polygon, box

# TERRAIN with the other constants: part of this module's interface.
from .synthetic_parts import (DEFAULT_THRESHOLDS, ORIGIN, SIZE, TERRAIN, BlockTruth, Part,  # noqa: F401
                              block_truth, part_triangles, terrain_local, wall_area)

CRS_EPSG = 2056
WALL_DENSITY = 0.5  # facade points per m2 of wall: airborne scanners see walls poorly


def las_header(extent: tuple[float, float, float, float], crs: bool) -> "laspy.LasHeader":  # noqa: F821
    """LAS 1.4 point format 6 header, millimetre scale, offset at the extent's corner."""
    import laspy
    import pyproj

    header = laspy.LasHeader(point_format=6, version="1.4")
    header.offsets = np.array([extent[0], extent[1], 0.0])
    header.scales = np.array([0.001, 0.001, 0.001])
    header.creation_date = datetime.date(2024, 1, 1)  # byte-identical reruns
    header.generating_software = "urbanvox synthetic"
    if crs:
        header.add_crs(pyproj.CRS.from_epsg(CRS_EPSG))
    return header


def _write_binary_stl(path, tris_world: np.ndarray, header: bytes) -> int:
    dt = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    rec = np.zeros(len(tris_world), dt)
    nrm = np.cross(tris_world[:, 1] - tris_world[:, 0], tris_world[:, 2] - tris_world[:, 0])
    rec["n"] = nrm / np.maximum(np.linalg.norm(nrm, axis=1), 1e-30)[:, None]
    rec["v"] = tris_world  # cast to float32 here, from float64 world coordinates
    with open(path, "wb") as f:
        f.write(header[:80].ljust(80, b" "))
        f.write(np.uint32(len(rec)).tobytes())
        f.write(rec.tobytes())
    return len(rec)


@dataclass
class District:
    """The synthetic district: extent, truth blocks, and writers for LAS/STL data.

    Examples
    --------
    >>> d = make_district()
    >>> x0, y0, x1, y1 = d.extent
    >>> float(d.terrain_z(x0, y0))
    400.0
    >>> t = next(b for b in d.blocks if b.name == "tower")
    >>> float(d.surface_z(*t.centroid)) == t.top_z
    True
    """

    extent: tuple[float, float, float, float]
    blocks: list[BlockTruth]
    seed: int = 0
    _parts: list[Part] = field(default_factory=list, repr=False, compare=False)
    _trees: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)), repr=False, compare=False)
    _walls: np.ndarray = field(default_factory=lambda: np.zeros((0, 8)), repr=False, compare=False)

    def terrain_z(self, x, y) -> np.ndarray:
        """Terrain height at world ``x, y`` (vectorised)."""
        return terrain_local(np.asarray(x, float) - ORIGIN[0], np.asarray(y, float) - ORIGIN[1])

    def _roof_local(self, xl: np.ndarray, yl: np.ndarray) -> np.ndarray:
        """Highest roof over local ``xl, yl``; -inf where there is no building."""
        z = np.full(xl.shape, -np.inf)
        # Points sorted by x once: each part then looks at the slice under its x range,
        # not at every point (a city tile has 100+ parts and ~800k points).
        order = np.argsort(xl, kind="stable")
        xs = xl[order]
        for p in self._parts:
            x0, y0, x1, y1 = p.bbox()
            near = order[np.searchsorted(xs, x0, "left"):np.searchsorted(xs, x1, "right")]
            idx = np.sort(near[(yl[near] >= y0) & (yl[near] <= y1)])
            if idx.size:
                u, v = p.to_uv(xl[idx], yl[idx])
                inside = (np.abs(u) <= p.length / 2 + 1e-9) & (np.abs(v) <= p.width / 2 + 1e-9)
                idx, zr = idx[inside], p.roof_uv(u[inside], v[inside])
                z[idx] = np.maximum(z[idx], zr)
        return z

    def surface_z(self, x, y) -> np.ndarray:
        """Top of terrain and roofs at world ``x, y`` (a DSM without vegetation)."""
        xl = np.atleast_1d(np.asarray(x, float) - ORIGIN[0])
        yl = np.atleast_1d(np.asarray(y, float) - ORIGIN[1])
        z = np.maximum(self._roof_local(xl.ravel(), yl.ravel()), terrain_local(xl, yl).ravel())
        return z.reshape(np.broadcast(np.asarray(x), np.asarray(y)).shape)

    def write_las(self, path, *, density: float = 12.0, seed: int | None = None,
                  crs: bool = True) -> int:
        """Write an airborne-like LAS 1.4 / point format 6 cloud (LAZ if ``.laz``).

        Parameters
        ----------
        path : str or Path
            Output file; compressed when it ends with ``.laz``.
        density : float
            Pulses per m2 over the extent (facade, noise and corner points come on top).
        seed : int, optional
            Random seed of the points; defaults to the district seed.
        crs : bool
            Write EPSG:2056 as a WKT VLR.

        Returns
        -------
        int
            Number of points written.

        Examples
        --------

        >>> import tempfile, os, laspy
        >>> path = os.path.join(tempfile.mkdtemp(), "d.laz")
        >>> n = make_district().write_las(path, density=1.0)
        >>> laspy.read(path).header.parse_crs().to_epsg()
        2056
        """
        import laspy

        rng = np.random.default_rng(self.seed if seed is None else seed)
        X, Y, Z, C = self._airborne_points(rng, density)

        las = laspy.LasData(las_header(self.extent, crs))
        las.x, las.y, las.z = X + ORIGIN[0], Y + ORIGIN[1], Z
        las.classification = C
        las.return_number = np.ones(X.size, np.uint8)
        las.number_of_returns = np.ones(X.size, np.uint8)
        las.gps_time = np.arange(X.size) * 1e-5
        las.write(str(path))
        return int(X.size)

    def _airborne_points(self, rng: np.random.Generator, density: float
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Local x, y, z and class of an airborne-like cloud (see :meth:`write_las`)."""
        n = rng.poisson(density * SIZE * SIZE)
        x, y = rng.random(n) * SIZE, rng.random(n) * SIZE
        roof = self._roof_local(x, y)
        terrain = terrain_local(x, y)
        is_roof = np.isfinite(roof)
        z = np.where(is_roof, roof, terrain)
        cls = np.where(is_roof, 6, 2).astype(np.uint8)
        for tx, ty, r, htop in self._trees:
            d2 = ((x - tx) ** 2 + (y - ty) ** 2) / r**2
            hit = np.flatnonzero(d2 <= 1)
            # over roofs the crown hides the roof; over the ground some pulses reach it
            keep = is_roof[hit] | (rng.random(hit.size) < 0.6)
            hit = hit[keep]
            crown = float(terrain_local(tx, ty)) + htop - 0.35 * r * d2[hit]
            z[hit] = np.maximum(crown, z[hit] + 0.5)
            cls[hit] = 5
        # facade points on real walls
        w = self._walls
        area = wall_area(w[:, 6] - w[:, 4], w[:, 7] - w[:, 5], np.hypot(*(w[:, 2:4] - w[:, :2]).T))
        k = rng.poisson(WALL_DENSITY * area)
        wi = np.repeat(np.arange(len(w)), k)
        t, s = rng.random(wi.size), rng.random(wi.size)
        fw = w[wi]
        lo = fw[:, 4] + t * (fw[:, 5] - fw[:, 4])
        hi = fw[:, 6] + t * (fw[:, 7] - fw[:, 6])
        fx = fw[:, 0] + t * (fw[:, 2] - fw[:, 0])
        fy = fw[:, 1] + t * (fw[:, 3] - fw[:, 1])
        fz = lo + s * (hi - lo)
        # outliers: birds / multipath far above, low points far below the ground
        nx, ny = rng.random(36) * SIZE, rng.random(36) * SIZE
        top = np.maximum(self._roof_local(nx[:24], ny[:24]), terrain_local(nx[:24], ny[:24]))
        nz = np.concatenate([top + rng.uniform(40, 150, 24),
                             terrain_local(nx[24:], ny[24:]) - rng.uniform(2, 15, 12)])
        cx, cy = np.array([0, SIZE, SIZE, 0.0]), np.array([0, 0, SIZE, SIZE])
        X = np.concatenate([x, fx, nx, cx])
        Y = np.concatenate([y, fy, ny, cy])
        Z = np.concatenate([z, fz, nz, terrain_local(cx, cy)])
        C = np.concatenate([cls, np.full(fx.size, 6, np.uint8), np.full(36, 7, np.uint8),
                            np.full(4, 2, np.uint8)])
        Z = Z + rng.normal(0.0, 0.025, Z.size)

        return X, Y, Z, C

    def part_meshes(self) -> list[tuple[Part, np.ndarray]]:
        """Per part, its triangles in world coordinates (float64, before the STL cast)."""
        off = np.array([ORIGIN[0], ORIGIN[1], 0.0])
        return [(p, part_triangles(p) + off) for p in self._parts]

    def write_stl(self, path) -> int:
        """Binary STL of the buildings only (float32 world coords); returns triangles."""
        tris = np.concatenate([t for _, t in self.part_meshes()])
        return _write_binary_stl(path, tris, b"urbanvox synthetic buildings EPSG:2056")

    def write_ground_stl(self, path, step: float = 10.0) -> int:
        """The terrain over the extent as a ``step`` m triangulated grid; returns triangles."""
        g = np.linspace(0.0, SIZE, int(round(SIZE / step)) + 1)
        gx, gy = np.meshgrid(g, g, indexing="ij")
        v = np.stack([gx + ORIGIN[0], gy + ORIGIN[1], terrain_local(gx, gy)], axis=-1)
        a, b, c, d = v[:-1, :-1], v[1:, :-1], v[1:, 1:], v[:-1, 1:]
        tris = np.concatenate([np.stack([a, b, c], -2).reshape(-1, 3, 3),
                               np.stack([a, c, d], -2).reshape(-1, 3, 3)])  # CCW: normals up
        return _write_binary_stl(path, tris, b"urbanvox synthetic terrain EPSG:2056")

    def truth_table(self) -> list[dict]:
        """The blocks as JSON-ready dicts (centroid as a list)."""
        return [{**asdict(b), "centroid": list(b.centroid)} for b in self.blocks]


def _special_parts() -> list[Part]:
    """The hand-placed buildings (local coords, corners on a 0.5 m grid)."""
    P = Part
    parts = [
        P("rotated45", 50, 200, 16, 10, 9, angle=45),  # the paper's figure-5 building
        P("tower", 200, 200, 12, 12, 60, floor=False),
        P("hip_roof", 50, 110, 20, 12, 7, 4, "hip"),
        P("gable_house_1", 80, 170, 14, 9, 6, 3.5, "gable", winding="mixed"),
        P("gable_house_2", 170, 140, 16, 10, 7, 3, "gable", angle=90, floor=False),
        P("shed", 102.75, 44, 2.5, 2, 2),  # fails all three default thresholds
        P("low_kiosk", 114.5, 44, 5, 4, 1.5),  # fails the height threshold only
        P("tiny_hut", 109.25, 56.25, 2.5, 2.5, 4),  # fails the footprint threshold only
        P("border_cut", 250, 110, 24, 16, 9, 4, "gable"),  # half outside the extent
        # intersecting boxes: each a closed box in the STL (inner faces), union in the truth
        P("intersecting_boxes", 185, 62, 34, 10, 13),
        P("intersecting_boxes", 182, 65, 30, 10, 12, 4, "gable", angle=90, winding="inverted"),
        P("intersecting_boxes", 190, 68, 12, 12, 18),
    ]
    # courtyard: 4 touching wings, inner yard 20 m x 14 m open to the sky
    parts += [P("courtyard", 125, 114, 36, 8, 15), P("courtyard", 125, 136, 36, 8, 15),
              P("courtyard", 111, 125, 8, 14, 12, floor=False),
              P("courtyard", 139, 125, 8, 14, 12, floor=False)]
    # row of 4 houses sharing party walls (gable ends), different heights, open bottoms
    for k, (h, rise, roof) in enumerate([(6, 3, "gable"), (7.5, 3.5, "gable"),
                                         (6.5, 0, "flat"), (8, 3, "gable")]):
        parts.append(P("row_houses", 51.5 + 9 * k, 50, 9, 11, h, rise, roof, floor=False))
    return parts


# trees: local x, y, crown radius, crown top above terrain; two overhang roofs
_TREES = np.array([[62.5, 117.0, 4.0, 14.0],   # over the hip roof edge
                   [117.5, 125.0, 5.0, 15.0],  # in the courtyard, over the west wing
                   [18.0, 22.0, 4.0, 10.0], [228.0, 228.0, 5.0, 12.0],
                   [140.0, 230.0, 3.0, 8.0], [88.0, 95.0, 3.5, 9.0]])


def make_district(seed: int = 0) -> District:
    """Build the district; ``seed`` varies the ordinary boxes, the special ones are fixed.

    Parameters
    ----------
    seed : int
        Seed of the ordinary boxes' sizes, heights, roofs and STL flaws.

    Returns
    -------
    District
        Truth blocks in order: the special buildings, then ``box_i_j`` by slot.

    Examples
    --------
    >>> a, b = make_district(0), make_district(0)
    >>> a.truth_table() == b.truth_table()
    True
    """
    rng = np.random.default_rng(seed)
    parts = _special_parts()
    taken = shapely.union_all([Polygon(p.to_xy(p.corners_uv())) for p in parts])
    taken = shapely.union_all([taken.buffer(4.0, join_style="mitre")]
                              + [shapely.Point(t[:2]).buffer(t[2] + 1.0) for t in _TREES])
    # ordinary boxes: one candidate per 30 m slot, inset 3 m -> >= 6 m between them
    for i in range(8):
        for j in range(8):
            L, W = rng.integers(16, 45, 2) / 2  # 8 .. 22 m
            kx, ky = rng.integers(0, 1000, 2)
            h = rng.integers(8, 51) / 2  # 4 .. 25 m
            gable, rise = rng.random() < 0.25, rng.integers(4, 9) / 2
            floor, wind = rng.random() < 0.5, rng.choice(["ok", "ok", "ok", "inverted", "mixed"])
            x0 = 8 + 30 * i + (kx % (int(2 * (24 - L)) + 1)) / 2
            y0 = 8 + 30 * j + (ky % (int(2 * (24 - W)) + 1)) / 2
            fp = box(x0, y0, x0 + L, y0 + W)
            if fp.intersects(taken):
                continue
            long_x = L >= W
            parts.append(Part(f"box_{i}_{j}", x0 + L / 2, y0 + W / 2, max(L, W), min(L, W),
                               float(h), float(rise) if gable else 0.0,
                               "gable" if gable else "flat", 0 if long_x else 90,
                               bool(floor), str(wind)))
    return district_from_parts(parts, seed, _TREES.copy())


def district_from_parts(parts: list[Part], seed: int, trees: np.ndarray) -> District:
    """A 250 m tile from its parts: one truth block per block name, in order of first part."""
    blocks, walls = [], []
    for name in dict.fromkeys(p.block for p in parts):
        bt, w = block_truth(name, [p for p in parts if p.block == name])
        blocks.append(bt)
        walls.append(w)
    extent = (ORIGIN[0], ORIGIN[1], ORIGIN[0] + SIZE, ORIGIN[1] + SIZE)
    return District(extent, blocks, seed, parts, trees, np.vstack(walls))


def main(argv: list[str] | None = None) -> int:
    """CLI: ``python -m core.synthetic OUTDIR [SEED]`` writes LAZ, STLs and truth.json;
    ``python -m core.synthetic --city OUTDIR [--size M] [--seed N] [--density D] [--las]``
    writes city.laz (or city.las) and city_truth.json."""
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "--city":
        from .synthetic_city import main as city_main

        return city_main(argv[1:])
    if not argv:
        print("usage: python -m core.synthetic OUTDIR [SEED]\n"
              "       python -m core.synthetic --city OUTDIR [--size M] [--seed N] [--density D] [--las]",
              file=sys.stderr)
        return 2
    out = Path(argv[0])
    out.mkdir(parents=True, exist_ok=True)
    d = make_district(int(argv[1]) if len(argv) > 1 else 0)
    n = d.write_las(out / "district.laz")
    t = d.write_stl(out / "district.stl")
    g = d.write_ground_stl(out / "district_ground.stl")
    doc = {"crs_epsg": CRS_EPSG, "extent": list(d.extent), "seed": d.seed,
           "thresholds": DEFAULT_THRESHOLDS, "blocks": d.truth_table()}
    (out / "truth.json").write_text(json.dumps(doc, indent=1))
    print(f"{n} points, {t} building triangles, {g} ground triangles, "
          f"{len(d.blocks)} blocks -> {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
