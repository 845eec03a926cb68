"""Building parts of the synthetic data and their exact, analytic truth.

The district (:mod:`core.synthetic`) and the city (:mod:`core.synthetic_city`)
are made of *parts*: rectangles (possibly rotated) with a flat, gable or hip
roof whose eave is at the absolute height ``terrain(part centre) + h``, on the
terrain plane ``z = 400 + 0.02 * (x - x0) + 0.01 * (y - y0)`` of a 250 m
square whose south-west corner is ``ORIGIN``. This module holds the parts,
their STL triangles and the truth of the blocks they form.

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

Example
-------
Two touching flat boxes of 10 x 10 m, 6 m and 9 m high, are one block:

>>> a = Part("b", 20.0, 20.0, 10.0, 10.0, 6.0)
>>> b = Part("b", 30.0, 20.0, 10.0, 10.0, 9.0)
>>> truth, _ = block_truth("b", [a, b])
>>> round(truth.footprint_area, 6)
200.0
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import shapely
import shapely.affinity
from shapely.geometry import Polygon, box

ORIGIN = (2_600_000.0, 1_200_000.0)
SIZE = 250.0
TERRAIN = (400.0, 0.02, 0.01)  # z = a + b * x_local + c * y_local
DEFAULT_THRESHOLDS = {"min_height": 2.5, "min_footprint": 10.0, "min_volume": 20.0}
_EXTENT_LOCAL = box(0.0, 0.0, SIZE, SIZE)


def terrain_local(x, y):
    """Terrain height at local coordinates (metres from ``ORIGIN``)."""
    return TERRAIN[0] + TERRAIN[1] * np.asarray(x, float) + TERRAIN[2] * np.asarray(y, float)


def _cos_sin(deg: float) -> tuple[float, float]:
    # exact values for right angles keep axis-aligned corners exactly on the 0.5 m grid
    exact = {0: (1.0, 0.0), 90: (0.0, 1.0), 180: (-1.0, 0.0), 270: (0.0, -1.0)}
    if deg % 90 == 0:
        return exact[int(deg) % 360]
    return float(np.cos(np.radians(deg))), float(np.sin(np.radians(deg)))


@dataclass(frozen=True)
class Part:
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
        return float(terrain_local(self.cx, self.cy)) + self.h

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


def wall_area(d0, d1, length):
    """Exact integral of |d| along a segment where d varies linearly from d0 to d1."""
    a0, a1 = np.abs(d0), np.abs(d1)
    same = d0 * d1 >= 0
    den = np.where(same, 1.0, a0 + a1)
    return length * np.where(same, (a0 + a1) / 2, (a0**2 + a1**2) / (2 * den))


def block_truth(name: str, parts: list[Part]) -> tuple[BlockTruth, np.ndarray]:
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
    volume -= foot.area * float(terrain_local(fc.x, fc.y))
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
        zp, zq = terrain_local(*P.T), terrain_local(*Q.T)
        for r, q in regions:
            hit = shapely.contains_xy(r, side[:, 0], side[:, 1])
            zp = np.where(hit, _plane(q, *P.T), zp)
            zq = np.where(hit, _plane(q, *Q.T), zq)
        zs.append((zp, zq))
    (lp, lq), (rp, rq) = zs
    wall = wall_area(lp - rp, lq - rq, length)
    surface = roof_area + wall.sum()
    # wall pieces for facade points; skip the cut face on the border (not a real wall)
    side_out = mid - 1e-6 * n
    real = (wall > 1e-9) & shapely.contains_xy(_EXTENT_LOCAL, *(mid + 1e-6 * n).T) \
        & shapely.contains_xy(_EXTENT_LOCAL, *side_out.T)
    walls = np.column_stack([P, Q, np.minimum(lp, rp), np.minimum(lq, rq),
                             np.maximum(lp, rp), np.maximum(lq, rq)])[real]
    top = max(_plane(q, *np.asarray(g.exterior.coords).T).max() for g, q in facets)
    hull = np.asarray(foot.convex_hull.exterior.coords)
    ground = float(terrain_local(*hull.T).min())  # planar terrain: lowest at a vertex
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


def part_triangles(p: Part) -> np.ndarray:
    """Walls + roof (+ floor) of one part, local coords, float64 (m, 3, 3)."""
    corners = p.corners_uv()
    base = float(terrain_local(*p.to_xy(corners).T).min()) - 0.2  # walls reach below ground
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
