"""MultiPolygonZ WKB of many small polygons, written by numpy.

The GIS layers hold each block's surface as a MultiPolygonZ of its faces: a
city has millions of faces, and a geometry object per face (shapely) took
longer than writing the rest of the outputs. Every face here is a ring of the
same number of corners, so its WKB has a fixed size: the polygons are one
packed structured array, and each multipolygon a header before a slice of it.
The bytes are those of ``shapely.to_wkb(multipolygons, output_dimension=3)``
(little endian, the Z flag of extended WKB).
"""
from __future__ import annotations

import numpy as np

_LITTLE_ENDIAN = 1
_Z = 0x80000000
_POLYGON, _MULTIPOLYGON = 3, 6


def multipolygons_z(rings: np.ndarray, group: np.ndarray, n_groups: int) -> list[bytes]:
    """WKB of ``n_groups`` MultiPolygonZ, group ``g`` made of the rings ``group == g``.

    Parameters
    ----------
    rings : ndarray of float (F, K, 3)
        Closed rings (last corner = first), one single-ring polygon each.
    group : ndarray of int (F,)
        The multipolygon of each ring, ascending.
    n_groups : int

    Returns
    -------
    list of bytes
        One WKB per group, its polygons in the order of ``rings``.

    Examples
    --------
    >>> import shapely
    >>> ring = np.array([[[0, 0, 1], [1, 0, 1], [0, 1, 1], [0, 0, 1.0]]])
    >>> wkb = multipolygons_z(np.concatenate([ring, ring + 2]), np.array([0, 0]), 1)
    >>> wkb[0] == shapely.to_wkb(shapely.multipolygons(shapely.polygons(np.concatenate([ring, ring + 2]))),
    ...                          output_dimension=3)
    True
    """
    n, k = rings.shape[:2]
    polygon = np.dtype([("order", "u1"), ("type", "<u4"), ("rings", "<u4"), ("points", "<u4"),
                        ("xyz", "<f8", (k, 3))])
    records = np.empty(n, dtype=polygon)
    records["order"] = _LITTLE_ENDIAN
    records["type"] = _Z | _POLYGON
    records["rings"] = 1
    records["points"] = k
    records["xyz"] = rings
    body = records.tobytes()
    bounds = np.searchsorted(group, np.arange(n_groups + 1))
    header = np.dtype([("order", "u1"), ("type", "<u4"), ("count", "<u4")])
    out = []
    for g in range(n_groups):
        head = np.array([(_LITTLE_ENDIAN, _Z | _MULTIPOLYGON, bounds[g + 1] - bounds[g])], dtype=header)
        out.append(head.tobytes() + body[bounds[g] * polygon.itemsize:bounds[g + 1] * polygon.itemsize])
    return out
