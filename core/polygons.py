"""Triangles of planar polygons with holes: the surfaces of a city model.

A CityJSON (CityGML) surface is a polygon in 3D: an outer ring and any holes,
each a list of vertices, planar up to the data's rounding. The voxelisation
samples triangles (§2), so each polygon is cut into triangles that cover it
and use its own vertices:

- a convex polygon without holes (most walls and roof faces: a quad, a
  triangle) is a fan from its first corner;
- any other is drawn flat on the two coordinates its plane spreads most
  along (its normal's largest component dropped: the coordinates stay the
  data's own, no rotation) and cut by a constrained Delaunay triangulation
  (shapely's, GEOS >= 3.10), whose triangles' corners are the polygon's
  corners: each is matched back to its vertex exactly. A self-intersecting
  polygon is first made valid (shapely's ``make_valid``); the corners that
  adds are put back in 3D on the plane of the outer ring (Newell's normal
  through its centroid).

All polygons at once: the rings are flat arrays with their sizes (the
layout of a ragged array), and nothing loops over polygons in Python.

Example
-------
An L-shaped roof (concave: not a fan) and a square with a square hole:

>>> vertices = np.array([[0, 0, 5], [4, 0, 5], [4, 1, 5], [1, 1, 5], [1, 3, 5], [0, 3, 5],
...                      [0, 0, 0], [3, 0, 0], [3, 3, 0], [0, 3, 0],
...                      [1, 1, 0], [1, 2, 0], [2, 2, 0], [2, 1, 0]], float)
>>> index = np.arange(14)
>>> all_vertices, faces, polygon = triangulate_polygons(vertices, index, np.array([6, 4, 4]), np.array([1, 2]))
>>> len(all_vertices), len(faces), np.bincount(polygon).tolist()
(14, 12, [4, 8])
>>> corners = all_vertices[faces]
>>> area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
>>> float(area.sum())  # 6 + (9 - 1)
14.0
"""
from __future__ import annotations

import numpy as np

from .errors import UrbanvoxError
from .topology import unique_rows

__all__ = ["triangulate_polygons", "newell_normals"]

#: The two coordinates a polygon is drawn on, by the axis dropped (its normal's largest component).
_KEPT_AXES = np.array([[1, 2], [0, 2], [0, 1]])


def triangulate_polygons(vertices: np.ndarray, index: np.ndarray, ring_sizes: np.ndarray,
                         ring_counts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Triangles covering every polygon.

    Parameters
    ----------
    vertices : ndarray (V, 3)
    index : ndarray of int (N,)
        The vertex of every ring corner, ring after ring; a ring is not
        closed (its first vertex is not repeated at its end).
    ring_sizes : ndarray of int (R,)
        Corners of each ring.
    ring_counts : ndarray of int (S,)
        Rings of each polygon, one polygon after another: its outer ring,
        then its holes. Rings of fewer than three corners are left out (a
        polygon whose outer ring is one of them, whole).

    Returns
    -------
    vertices : ndarray (V + W, 3)
        ``vertices``, then the W corners that making self-intersecting
        polygons valid added, on their polygons' planes.
    faces : ndarray of int (F, 3)
        Fans first, polygon by polygon, then the other polygons' triangles;
        each turns as its polygon's outer ring does (the same normal).
    polygon : ndarray of int (F,)
        The polygon each triangle covers, numbered as ``ring_counts`` is
        (so that a city object's triangles can be told apart).
    """
    index, ring_sizes, ring_counts, number = _drop_short_rings(np.asarray(index, dtype=np.int64),
                                                               np.asarray(ring_sizes, dtype=np.int64),
                                                               np.asarray(ring_counts, dtype=np.int64))
    if len(ring_counts) == 0:
        return vertices, np.empty((0, 3), dtype=np.int64), np.empty(0, dtype=np.int64)
    rings = _Rings(vertices, index, ring_sizes, ring_counts)
    fan = (ring_counts == 1) & rings.convex()[rings.first]
    fan_polygons = np.flatnonzero(fan)
    faces = [_fans(index, rings, rings.first[fan_polygons])]
    polygon = [np.repeat(fan_polygons, rings.sizes[rings.first[fan_polygons]] - 2)]
    others = np.flatnonzero(~fan)
    if len(others):
        vertices, flat_faces, flat_polygon = _constrained(vertices, index, rings, others)
        faces.append(flat_faces)
        polygon.append(flat_polygon)
    return vertices, np.concatenate(faces), number.take(np.concatenate(polygon))


def newell_normals(points: np.ndarray, ring_start: np.ndarray, ring_sizes: np.ndarray) -> np.ndarray:
    """Newell's normal of every ring (twice its vector area), corners relative
    to the ring's first for precision at projected coordinates.

    Example
    -------
    >>> square = np.array([[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0]], float) + 1e6
    >>> newell_normals(square, np.array([0]), np.array([4])).tolist()
    [[0.0, 0.0, 8.0]]
    """
    corner_ring = np.repeat(np.arange(len(ring_sizes)), ring_sizes)
    q = points - points[ring_start[corner_ring]]
    following = _following(ring_start, ring_sizes)
    x, y, z = q.T
    xn, yn, zn = q[following].T
    terms = np.stack([(y - yn) * (z + zn), (z - zn) * (x + xn), (x - xn) * (y + yn)], axis=1)
    return np.add.reduceat(terms, ring_start, axis=0)


class _Rings:
    """The rings' layout and each polygon's flat drawing (the kept coordinates ``uv``)."""

    def __init__(self, vertices: np.ndarray, index: np.ndarray, ring_sizes: np.ndarray, ring_counts: np.ndarray):
        self.sizes = ring_sizes
        self.counts = ring_counts
        self.start = np.cumsum(ring_sizes) - ring_sizes
        self.first = np.cumsum(ring_counts) - ring_counts  # each polygon's outer ring
        self.polygon = np.repeat(np.arange(len(ring_counts)), ring_counts)  # of each ring
        self.corner_ring = np.repeat(np.arange(len(ring_sizes)), ring_sizes)
        self.points = vertices.take(index, axis=0)
        self.normal = newell_normals(self.points, self.start, ring_sizes)[self.first]  # each polygon's
        # A planar polygon's Newell normal is its plane's, scaled by its signed
        # area: nothing left of it for a bow tie whose lobes cancel. Those take
        # the axis of least spread of their outer ring's corners.
        extent = np.maximum.reduceat(self.points, self.start, axis=0) - np.minimum.reduceat(
            self.points, self.start, axis=0)
        lost = np.flatnonzero(np.linalg.norm(self.normal, axis=1) <= 1e-9 * (extent[self.first] ** 2).sum(axis=1))
        if len(lost):
            self.normal[lost] = self._least_axes(self.first[lost])
        self.dropped = np.argmax(np.abs(self.normal), axis=1)
        kept = _KEPT_AXES[self.dropped][self.polygon[self.corner_ring]]
        self.uv = np.take_along_axis(self.points, kept, axis=1)

    def _least_axes(self, rings: np.ndarray) -> np.ndarray:
        """The direction of least spread of each ring's corners (the normal of its best plane)."""
        sizes = self.sizes[rings]
        owner = np.repeat(np.arange(len(rings)), sizes)
        corners = self.start[rings][owner] + np.arange(int(sizes.sum())) - np.repeat(np.cumsum(sizes) - sizes, sizes)
        offset = self.points[corners] - self.points[self.start[rings]][owner]
        centred = offset - (np.stack([np.bincount(owner, weights=offset[:, c]) for c in range(3)], axis=1)
                            / self.sizes[rings, None])[owner]
        moments = np.zeros((len(rings), 3, 3))
        np.add.at(moments, owner, centred[:, :, None] * centred[:, None, :])
        return np.linalg.eigh(moments)[1][:, :, 0]

    def convex(self) -> np.ndarray:
        """Whether each ring turns one way only, once around (a fan then covers it)."""
        following = _following(self.start, self.sizes)
        edge = self.uv[following] - self.uv
        previous = np.empty_like(following)
        previous[following] = np.arange(len(following))
        before = edge[previous]
        cross = before[:, 0] * edge[:, 1] - before[:, 1] * edge[:, 0]
        turn = np.arctan2(cross, np.einsum("ij,ij->i", before, edge))
        one_way = (np.minimum.reduceat(cross, self.start) >= 0) | (np.maximum.reduceat(cross, self.start) <= 0)
        # A star turns one way too, twice around.
        return one_way & (np.abs(np.add.reduceat(turn, self.start)) < 3 * np.pi)


def _following(ring_start: np.ndarray, ring_sizes: np.ndarray) -> np.ndarray:
    """The next corner of every corner in its ring (the last's is the ring's first)."""
    following = np.arange(1, int(ring_sizes.sum()) + 1)
    following[ring_start + ring_sizes - 1] = ring_start
    return following


def _drop_short_rings(index: np.ndarray, ring_sizes: np.ndarray, ring_counts: np.ndarray):
    """The rings of three corners or more, and the polygons whose outer ring is one; and
    the number of each polygon kept among those given."""
    number = np.flatnonzero(ring_counts > 0)
    ring_counts = ring_counts.take(number)
    short = ring_sizes < 3
    if not short.any():
        return index, ring_sizes, ring_counts, number
    first = np.cumsum(ring_counts) - ring_counts
    polygon = np.repeat(np.arange(len(ring_counts)), ring_counts)
    kept_polygon = ~short[first]
    kept_ring = ~short & kept_polygon[polygon]
    index = index[np.repeat(kept_ring, ring_sizes)]
    ring_counts = np.bincount(polygon[kept_ring], minlength=len(ring_counts))[kept_polygon]
    return index, ring_sizes[kept_ring], ring_counts, number.compress(kept_polygon)


def _fans(index: np.ndarray, rings: _Rings, fan_rings: np.ndarray) -> np.ndarray:
    """Triangles (first, j, j + 1) of each ring, j = 1 .. size - 2."""
    count = rings.sizes[fan_rings] - 2
    ring = np.repeat(fan_rings, count)
    j = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count) + 1
    first = rings.start[ring]
    return np.stack([index[first], index[first + j], index[first + j + 1]], axis=1)


def _constrained(vertices: np.ndarray, index: np.ndarray, rings: _Rings,
                 polygons: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The constrained Delaunay triangles of ``polygons`` (see the module doc): the
    vertices with those added, the triangles, and the polygon of each."""
    import shapely

    if not hasattr(shapely, "constrained_delaunay_triangles"):
        raise UrbanvoxError("Polygons with holes or concave polygons need shapely 2.1 or later: "
                            "python3 -m pip install --upgrade 'shapely>=2.1'")
    wanted = np.zeros(len(rings.first), dtype=bool)
    wanted[polygons] = True
    ring_of = np.flatnonzero(wanted[rings.polygon])
    # Closed rings, as shapely's ragged arrays are: each ring's first corner again at its end.
    closed = rings.sizes[ring_of] + 1
    which = np.repeat(np.arange(len(ring_of)), closed)
    offset = np.arange(int(closed.sum())) - np.repeat(np.cumsum(closed) - closed, closed)
    corner = rings.start[ring_of][which] + np.where(offset == closed[which] - 1, 0, offset)
    ring_offsets = np.concatenate([[0], np.cumsum(closed)])
    polygon_offsets = np.concatenate([[0], np.cumsum(rings.counts[polygons])])
    shapes = shapely.from_ragged_array(shapely.GeometryType.POLYGON, rings.uv[corner],
                                       (ring_offsets, polygon_offsets))
    invalid = ~shapely.is_valid(shapes)
    if invalid.any():
        shapes[invalid] = shapely.make_valid(shapes[invalid], method="structure", keep_collapsed=False)
    triangles, owner = shapely.get_parts(shapely.constrained_delaunay_triangles(shapes), return_index=True)
    closed_triangle = shapely.get_num_coordinates(triangles) == 4
    triangles, owner = triangles[closed_triangle], owner[closed_triangle]
    uv = shapely.get_coordinates(triangles).reshape(-1, 4, 2)[:, :3].reshape(-1, 2)
    polygon = np.repeat(polygons[owner], 3)
    # Each corner's vertex: the polygon's corner with the same kept coordinates.
    own = np.flatnonzero(wanted[rings.polygon[rings.corner_ring]])
    known = _keys(rings.polygon[rings.corner_ring[own]], rings.uv[own])
    key = unique_rows(np.concatenate([known, _keys(polygon, uv)]))[1]
    vertex = np.full(int(key.max()) + 1, -1, dtype=np.int64)
    vertex[key[:len(own)]] = index[own]
    found = vertex[key[len(own):]]
    added = np.flatnonzero(found < 0)
    if len(added):
        # One vertex per new corner, however many triangles share it.
        _, first, number = np.unique(key[len(own):][added], return_index=True, return_inverse=True)
        found[added] = len(vertices) + number
        vertices = np.concatenate([vertices, _lifted(rings, polygon[added[first]], uv[added[first]])])
    faces = found.reshape(-1, 3)
    # GEOS turns every triangle one way in the drawing; the polygon's own turn (its normal) is kept.
    corners = vertices[faces]
    turn = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    backwards = np.einsum("ij,ij->i", turn, rings.normal[polygon[::3]]) < 0
    faces[backwards] = faces[backwards][:, ::-1]
    return vertices, faces, polygon[::3]


def _keys(polygon: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """(polygon, u, v) rows of int64 that compare equal exactly when the coordinates do (-0.0 as 0.0)."""
    bits = np.ascontiguousarray(uv + 0.0).view(np.int64)
    return np.column_stack([polygon, bits])


def _lifted(rings: _Rings, polygon: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Points drawn at ``uv`` on ``polygon``'s drawing, back on the plane of its outer ring."""
    outer = rings.first[polygon]
    corners = rings.corner_ring
    centre = np.stack([np.bincount(corners, weights=rings.points[:, c], minlength=len(rings.sizes))
                       for c in range(3)], axis=1)[outer] / rings.sizes[outer, None]
    normal = rings.normal[polygon]
    dropped = rings.dropped[polygon]
    kept = _KEPT_AXES[dropped]
    point = np.empty((len(polygon), 3))
    np.put_along_axis(point, kept, uv, axis=1)
    rows = np.arange(len(polygon))
    n_kept = normal[rows[:, None], kept]
    c_kept = centre[rows[:, None], kept]
    n_dropped = normal[rows, dropped]
    height = centre[rows, dropped] - np.einsum("ij,ij->i", n_kept, uv - c_kept) / np.where(n_dropped == 0, 1.0,
                                                                                            n_dropped)
    point[rows, dropped] = height
    return point
