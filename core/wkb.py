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


def multipolygons_z(nodes: np.ndarray, faces: np.ndarray, group: np.ndarray, n_groups: int) -> list[bytes]:
    """WKB of ``n_groups`` MultiPolygonZ, group ``g`` made of the faces ``group == g``.

    Parameters
    ----------
    nodes : ndarray of float (N, 3)
    faces : ndarray of int (F, K)
        One single-ring polygon each: its corners, then the first again.
    group : ndarray of int (F,)
        The multipolygon of each face, ascending.
    n_groups : int

    Returns
    -------
    list of bytes
        One WKB per group, its polygons in the order of ``faces``.

    Examples
    --------
    >>> import shapely
    >>> nodes = np.array([[0, 0, 1], [1, 0, 1], [0, 1, 1], [2, 2, 3.0]])
    >>> faces = np.array([[0, 1, 2], [1, 3, 2]])
    >>> rings = nodes[np.concatenate([faces, faces[:, :1]], axis=1)]
    >>> wkb = multipolygons_z(nodes, faces, np.array([0, 0]), 1)
    >>> wkb[0] == shapely.to_wkb(shapely.multipolygons(shapely.polygons(rings)), output_dimension=3)
    True
    """
    n, k = faces.shape
    polygon = np.dtype([("order", "u1"), ("type", "<u4"), ("rings", "<u4"), ("points", "<u4"),
                        ("xyz", "<f8", (k + 1, 3))])
    records = np.empty(n, dtype=polygon)
    records["order"] = _LITTLE_ENDIAN
    records["type"] = _Z | _POLYGON
    records["rings"] = 1
    records["points"] = k + 1
    # Each corner straight into the records (no (F, K + 1, 3) table of the
    # closed rings: hundreds of MB for a city's blocks).
    xyz = records["xyz"]
    for corner in range(k):
        xyz[:, corner] = nodes.take(faces[:, corner], axis=0)  # take: faster rows (core.vectors)
    xyz[:, k] = xyz[:, 0]
    del xyz
    bounds = np.searchsorted(group, np.arange(n_groups + 1))
    header = np.dtype([("order", "u1"), ("type", "<u4"), ("count", "<u4")])
    out = []
    for g in range(n_groups):
        head = np.array([(_LITTLE_ENDIAN, _Z | _MULTIPOLYGON, bounds[g + 1] - bounds[g])], dtype=header)
        out.append(head.tobytes() + records[bounds[g]:bounds[g + 1]].tobytes())
    return out
