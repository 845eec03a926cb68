"""Synthetic city district with exact, analytic truth: the embedded default dataset.

The district is a 250 m x 250 m square in Swiss LV95 (EPSG:2056) whose south-west
corner is ``ORIGIN = (2_600_000, 1_200_000)``. Coordinates are deliberately large:
float32 has a 0.25 m step at x = 2.6e6, so code that drops to float32 too early
shows it. Every axis-aligned corner lies on a 0.5 m grid and is therefore exact in
the float32 STL; the ``rotated45`` corners are not (up to 0.125 m off, as in real data).

Terrain is the plane ``z = 400 + 0.02 * (x - x0) + 0.01 * (y - y0)``.
Each building *part* is a rectangle (possibly rotated) with a flat, gable or hip roof
whose eave is at the absolute height ``terrain(part centre) + h``.

Truth (what :class:`BlockTruth` means)
--------------------------------------
A *block* is a set of parts that touch or overlap; its solid is
``{(x, y, z): (x, y) in F, terrain(x, y) <= z <= roof(x, y)}`` where ``F`` is the
union of the part footprints clipped to the extent and ``roof`` the highest roof of
the parts over ``(x, y)``. Everything below the terrain (STL walls and floors that
reach under the ground) is not part of the truth. The roof is an upper envelope of
planes, so it is split exactly into planar regions (shapely clipping) and each
integral is ``area * value at centroid``: volumes, areas and surfaces are analytic,
not sampled. ``surface_area`` is roofs + every vertical wall above the terrain:
outer walls, the step walls between parts of different heights and, for the block
cut by the border, the vertical cut face on the extent border (the clipped solid is
closed there). Thresholds flagged by ``below_thresholds`` are
:data:`DEFAULT_THRESHOLDS`.

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
import shapely.affinity
from shapely.geometry import Polygon, box

CRS_EPSG = 2056
ORIGIN = (2_600_000.0, 1_200_000.0)
SIZE = 250.0
TERRAIN = (400.0, 0.02, 0.01)  # z = a + b * x_local + c * y_local
DEFAULT_THRESHOLDS = {"min_height": 2.5, "min_footprint": 10.0, "min_volume": 20.0}
WALL_DENSITY = 0.5  # facade points per m2 of wall: airborne scanners see walls poorly
_EXTENT_LOCAL = box(0.0, 0.0, SIZE, SIZE)


def _terrain_local(x, y):
    return TERRAIN[0] + TERRAIN[1] * np.asarray(x, float) + TERRAIN[2] * np.asarray(y, float)


def _cos_sin(deg: float) -> tuple[float, float]:
    # exact values for right angles keep axis-aligned corners exactly on the 0.5 m grid
    exact = {0: (1.0, 0.0), 90: (0.0, 1.0), 180: (-1.0, 0.0), 270: (0.0, -1.0)}
    if deg % 90 == 0:
        return exact[int(deg) % 360]
    return float(np.cos(np.radians(deg))), float(np.sin(np.radians(deg)))


@dataclass(frozen=True)
class _Part:
    """One building part: rectangle length (along the ridge u) x width (across, v)."""

    block: str
    cx: float
    cy: float
    length: float
    width: float
    h: float  # eave height above the terrain at the part centre
    rise: float = 0.0  # ridge minus eave; 0 for flat roofs
    roof: str = "flat"  # "flat" | "gable" | "hip"
    angle: float = 0.0  # degrees from +x to the ridge direction
    floor: bool = True  # STL: closed bottom (False = open like 3dfier)
    winding: str = "ok"  # STL: "ok" | "inverted" | "mixed"

    @property
    def eave(self) -> float:
        return float(_terrain_local(self.cx, self.cy)) + self.h

    def to_uv(self, x, y):
        c, s = _cos_sin(self.angle)
        dx, dy = x - self.cx, y - self.cy
        return dx * c + dy * s, -dx * s + dy * c

    def to_xy(self, uv: np.ndarray) -> np.ndarray:
        c, s = _cos_sin(self.angle)
        u, v = uv[:, 0], uv[:, 1]
        return np.column_stack([self.cx + u * c - v * s, self.cy + u * s + v * c])

    def roof_uv(self, u, v):
        hl, hw = self.length / 2, self.width / 2
        if self.roof == "flat":
            return np.full(np.shape(u), self.eave)
        d = hw - np.abs(v)
        if self.roof == "hip":
            d = np.minimum(d, hl - np.abs(u))
        return self.eave + self.rise / hw * d

    def corners_uv(self) -> np.ndarray:
        hl, hw = self.length / 2, self.width / 2
        return np.array([(-hl, -hw), (hl, -hw), (hl, hw), (-hl, hw)])

    def facets(self) -> list[tuple[np.ndarray, tuple[float, float, float]]]:
        """Roof facets as (CCW xy polygon, plane (a, bx, by) with z = a + bx x + by y)."""
        hl, hw, e = self.length / 2, self.width / 2, self.eave
        if self.roof == "flat":
            uv = [(self.corners_uv(), (e, 0.0, 0.0))]
        else:
            s = self.rise / hw
            r = hl - hw if self.roof == "hip" else hl  # half ridge length
            if self.roof == "hip" and r <= 0:
                raise ValueError("a hip roof needs length > width")
            uv = [(np.array([(-hl, -hw), (hl, -hw), (r, 0), (-r, 0)]), (e + s * hw, 0.0, s)),
                  (np.array([(-r, 0), (r, 0), (hl, hw), (-hl, hw)]), (e + s * hw, 0.0, -s))]
            if self.roof == "hip":
                uv += [(np.array([(hl, -hw), (hl, hw), (r, 0)]), (e + s * hl, -s, 0.0)),
                       (np.array([(-hl, hw), (-hl, -hw), (-r, 0)]), (e + s * hl, s, 0.0))]
        c, sn = _cos_sin(self.angle)
        out = []
        for poly, (a, bu, bv) in uv:
            bx, by = bu * c - bv * sn, bu * sn + bv * c  # plane gradient rotated to xy
            out.append((self.to_xy(poly.astype(float)), (a - bx * self.cx - by * self.cy, bx, by)))
        return out

    def bbox(self) -> tuple[float, float, float, float]:
        xy = self.to_xy(self.corners_uv())
        return xy[:, 0].min(), xy[:, 1].min(), xy[:, 0].max(), xy[:, 1].max()


@dataclass(frozen=True)
class BlockTruth:
    """One expected building block (touching parts merged); see the module docstring."""

    name: str
    volume: float
    footprint_area: float
    height: float
    top_z: float
    ground_z: float
    surface_area: float
    centroid: tuple[float, float]
    footprint_wkt: str
    below_thresholds: bool
    on_border: bool


def _plane(q, x, y):
    return q[0] + q[1] * x + q[2] * y


def _clip_positive(poly: np.ndarray, d) -> np.ndarray:
    """Sutherland-Hodgman: the part of convex ``poly`` where plane ``d`` >= 0."""
    val = _plane(d, poly[:, 0], poly[:, 1])
    out = []
    for i in range(len(poly)):
        j = (i + 1) % len(poly)
        if val[i] >= 0:
            out.append(poly[i])
        if (val[i] >= 0) != (val[j] >= 0):
            t = val[i] / (val[i] - val[j])
            out.append(poly[i] + t * (poly[j] - poly[i]))
    return np.array(out)


def _wall_area(d0, d1, length):
    """Exact integral of |d| along a segment where d varies linearly from d0 to d1."""
    a0, a1 = np.abs(d0), np.abs(d1)
    same = d0 * d1 >= 0
    den = np.where(same, 1.0, a0 + a1)
    return length * np.where(same, (a0 + a1) / 2, (a0**2 + a1**2) / (2 * den))


def _block_truth(name: str, parts: list[_Part]) -> tuple[BlockTruth, np.ndarray]:
    """Exact truth of one block and its wall pieces (for facade points)."""
    facets = []  # (shapely polygon clipped to the extent, plane)
    for p in parts:
        for xy, q in p.facets():
            g = Polygon(xy).intersection(_EXTENT_LOCAL)
            if g.area > 1e-9:
                facets.append((g, q))
    # upper envelope: facet i keeps the area where no other facet is higher
    regions = []
    for i, (gi, qi) in enumerate(facets):
        r = gi
        for j, (gj, qj) in enumerate(facets):
            if j == i or gi.intersection(gj).area <= 1e-9:
                continue
            d = np.subtract(qj, qi)
            if np.all(np.abs(d) < 1e-12):  # coplanar overlap belongs to the lower index
                cut = gj if j < i else None
            else:
                c = _clip_positive(np.asarray(gj.exterior.coords)[:-1], d)
                cut = Polygon(c) if len(c) >= 3 else None
            if cut is not None and cut.area > 0:
                r = r.difference(cut)
        if r.geom_type not in ("Polygon", "MultiPolygon"):  # drop stray lines/points
            r = shapely.union_all([g for g in shapely.get_parts(r) if g.geom_type == "Polygon"])
        if r.area > 1e-12:
            regions.append((r, qi))
    foot = shapely.union_all([g for g, _ in facets])
    fc = foot.centroid
    volume = sum(r.area * _plane(q, r.centroid.x, r.centroid.y) for r, q in regions)
    volume -= foot.area * float(_terrain_local(fc.x, fc.y))
    roof_area = sum(r.area * np.sqrt(1 + q[1] ** 2 + q[2] ** 2) for r, q in regions)
    # walls: node every region boundary, look at both sides of each segment
    lines = shapely.union_all([r.boundary for r, _ in regions])
    segs = []
    for ln in getattr(lines, "geoms", [lines]):
        c = np.asarray(ln.coords)
        segs.append(np.hstack([c[:-1], c[1:]]))
    segs = np.vstack(segs)
    P, Q = segs[:, :2], segs[:, 2:]
    length = np.hypot(*(Q - P).T)
    P, Q, length = P[length > 1e-9], Q[length > 1e-9], length[length > 1e-9]
    n = np.column_stack([-(Q - P)[:, 1], (Q - P)[:, 0]]) / length[:, None]
    mid = (P + Q) / 2
    zs = []  # z at P and Q seen from each side: a region's plane or the terrain
    for side in (mid + 1e-6 * n, mid - 1e-6 * n):
        zp, zq = _terrain_local(*P.T), _terrain_local(*Q.T)
        for r, q in regions:
            hit = shapely.contains_xy(r, side[:, 0], side[:, 1])
            zp = np.where(hit, _plane(q, *P.T), zp)
            zq = np.where(hit, _plane(q, *Q.T), zq)
        zs.append((zp, zq))
    (lp, lq), (rp, rq) = zs
    wall = _wall_area(lp - rp, lq - rq, length)
    surface = roof_area + wall.sum()
    # wall pieces for facade points; skip the cut face on the border (not a real wall)
    side_out = mid - 1e-6 * n
    real = (wall > 1e-9) & shapely.contains_xy(_EXTENT_LOCAL, *(mid + 1e-6 * n).T) \
        & shapely.contains_xy(_EXTENT_LOCAL, *side_out.T)
    walls = np.column_stack([P, Q, np.minimum(lp, rp), np.minimum(lq, rq),
                             np.maximum(lp, rp), np.maximum(lq, rq)])[real]
    top = max(_plane(q, *np.asarray(g.exterior.coords).T).max() for g, q in facets)
    hull = np.asarray(foot.convex_hull.exterior.coords)
    ground = float(_terrain_local(*hull.T).min())  # planar terrain: lowest at a vertex
    th = DEFAULT_THRESHOLDS
    height = top - ground
    world = shapely.affinity.translate(foot, *ORIGIN)
    bt = BlockTruth(
        name=name, volume=float(volume), footprint_area=float(foot.area),
        height=float(height), top_z=float(top), ground_z=ground, surface_area=float(surface),
        centroid=(ORIGIN[0] + fc.x, ORIGIN[1] + fc.y),
        footprint_wkt=shapely.to_wkt(world, rounding_precision=-1),
        below_thresholds=bool(height < th["min_height"] or foot.area < th["min_footprint"]
                               or volume < th["min_volume"]),
        on_border=bool(foot.intersects(_EXTENT_LOCAL.exterior)))
    return bt, walls


def _fan(poly: np.ndarray) -> np.ndarray:
    """Fan-triangulate a convex 3D polygon (k, 3) -> (k-2, 3, 3), keeping its winding."""
    return np.stack([np.stack([poly[0], poly[i], poly[i + 1]]) for i in range(1, len(poly) - 1)])


def _part_triangles(p: _Part) -> np.ndarray:
    """Walls + roof (+ floor) of one part, local coords, float64 (m, 3, 3)."""
    corners = p.corners_uv()
    base = float(_terrain_local(*p.to_xy(corners).T).min()) - 0.2  # walls reach below ground
    walls, roof = [], []
    for k in range(4):
        a, b = corners[k], corners[(k + 1) % 4]
        top = [a, b]
        if p.roof == "gable" and a[0] == b[0]:  # gable end: include the ridge end
            top = [a, np.array([a[0], 0.0]), b]
        top = np.array(top, float)
        ztop = p.roof_uv(top[:, 0], top[:, 1])
        xy = p.to_xy(top)
        ring = np.vstack([[*xy[0], base], [*xy[-1], base],
                          np.column_stack([xy, ztop])[::-1]])
        walls.append(_fan(ring))
    for xy, q in p.facets():
        roof.append(_fan(np.column_stack([xy, _plane(q, *xy.T)])))
    if p.winding == "mixed":  # flip walls 1 and 3: inconsistent normals like broken exports
        walls = [w[:, ::-1] if k % 2 else w for k, w in enumerate(walls)]
    tris = walls + roof
    if p.floor:
        xy = p.to_xy(corners)[::-1]
        tris.append(_fan(np.column_stack([xy, np.full(4, base)])))
    tris = np.concatenate(tris)
    return tris[:, ::-1] if p.winding == "inverted" else tris


def _las_header(extent: tuple[float, float, float, float], crs: bool) -> "laspy.LasHeader":  # noqa: F821
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
    _parts: list[_Part] = field(default_factory=list, repr=False, compare=False)
    _trees: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)), repr=False, compare=False)
    _walls: np.ndarray = field(default_factory=lambda: np.zeros((0, 8)), repr=False, compare=False)

    def terrain_z(self, x, y) -> np.ndarray:
        """Terrain height at world ``x, y`` (vectorised)."""
        return _terrain_local(np.asarray(x, float) - ORIGIN[0], np.asarray(y, float) - ORIGIN[1])

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
        z = np.maximum(self._roof_local(xl.ravel(), yl.ravel()), _terrain_local(xl, yl).ravel())
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

        las = laspy.LasData(_las_header(self.extent, crs))
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
        terrain = _terrain_local(x, y)
        is_roof = np.isfinite(roof)
        z = np.where(is_roof, roof, terrain)
        cls = np.where(is_roof, 6, 2).astype(np.uint8)
        for tx, ty, r, htop in self._trees:
            d2 = ((x - tx) ** 2 + (y - ty) ** 2) / r**2
            hit = np.flatnonzero(d2 <= 1)
            # over roofs the crown hides the roof; over the ground some pulses reach it
            keep = is_roof[hit] | (rng.random(hit.size) < 0.6)
            hit = hit[keep]
            crown = float(_terrain_local(tx, ty)) + htop - 0.35 * r * d2[hit]
            z[hit] = np.maximum(crown, z[hit] + 0.5)
            cls[hit] = 5
        # facade points on real walls
        w = self._walls
        area = _wall_area(w[:, 6] - w[:, 4], w[:, 7] - w[:, 5], np.hypot(*(w[:, 2:4] - w[:, :2]).T))
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
        top = np.maximum(self._roof_local(nx[:24], ny[:24]), _terrain_local(nx[:24], ny[:24]))
        nz = np.concatenate([top + rng.uniform(40, 150, 24),
                             _terrain_local(nx[24:], ny[24:]) - rng.uniform(2, 15, 12)])
        cx, cy = np.array([0, SIZE, SIZE, 0.0]), np.array([0, 0, SIZE, SIZE])
        X = np.concatenate([x, fx, nx, cx])
        Y = np.concatenate([y, fy, ny, cy])
        Z = np.concatenate([z, fz, nz, _terrain_local(cx, cy)])
        C = np.concatenate([cls, np.full(fx.size, 6, np.uint8), np.full(36, 7, np.uint8),
                            np.full(4, 2, np.uint8)])
        Z = Z + rng.normal(0.0, 0.025, Z.size)

        return X, Y, Z, C

    def _part_meshes(self) -> list[tuple[_Part, np.ndarray]]:
        """Per part, its triangles in world coordinates (float64, before the STL cast)."""
        off = np.array([ORIGIN[0], ORIGIN[1], 0.0])
        return [(p, _part_triangles(p) + off) for p in self._parts]

    def write_stl(self, path) -> int:
        """Binary STL of the buildings only (float32 world coords); returns triangles."""
        tris = np.concatenate([t for _, t in self._part_meshes()])
        return _write_binary_stl(path, tris, b"urbanvox synthetic buildings EPSG:2056")

    def write_ground_stl(self, path, step: float = 10.0) -> int:
        """The terrain over the extent as a ``step`` m triangulated grid; returns triangles."""
        g = np.linspace(0.0, SIZE, int(round(SIZE / step)) + 1)
        gx, gy = np.meshgrid(g, g, indexing="ij")
        v = np.stack([gx + ORIGIN[0], gy + ORIGIN[1], _terrain_local(gx, gy)], axis=-1)
        a, b, c, d = v[:-1, :-1], v[1:, :-1], v[1:, 1:], v[:-1, 1:]
        tris = np.concatenate([np.stack([a, b, c], -2).reshape(-1, 3, 3),
                               np.stack([a, c, d], -2).reshape(-1, 3, 3)])  # CCW: normals up
        return _write_binary_stl(path, tris, b"urbanvox synthetic terrain EPSG:2056")

    def truth_table(self) -> list[dict]:
        """The blocks as JSON-ready dicts (centroid as a list)."""
        return [{**asdict(b), "centroid": list(b.centroid)} for b in self.blocks]


def _special_parts() -> list[_Part]:
    """The hand-placed buildings (local coords, corners on a 0.5 m grid)."""
    P = _Part
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
            parts.append(_Part(f"box_{i}_{j}", x0 + L / 2, y0 + W / 2, max(L, W), min(L, W),
                               float(h), float(rise) if gable else 0.0,
                               "gable" if gable else "flat", 0 if long_x else 90,
                               bool(floor), str(wind)))
    return _district_of(parts, seed, _TREES.copy())


def _district_of(parts: list[_Part], seed: int, trees: np.ndarray) -> District:
    """A 250 m tile from its parts: one truth block per block name, in order of first part."""
    blocks, walls = [], []
    for name in dict.fromkeys(p.block for p in parts):
        bt, w = _block_truth(name, [p for p in parts if p.block == name])
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
