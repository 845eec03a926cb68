"""MultiPolygonZ WKB of many small polygons, written by numpy.

The GIS layers hold each block's surface as a MultiPolygonZ of its faces: a
city has millions of faces, and a geometry object per face (shapely) took
longer than writing the rest of the outputs. Every face here is a ring of the
same number of corners, so its WKB has a fixed size: the polygons are rows
of bytes, a chunk of faces at a time, and each multipolygon a header before
a slice of them.
The bytes are those of ``shapely.to_wkb(multipolygons, output_dimension=3)``
(little endian, the Z flag of extended WKB).
"""
from __future__ import annotations

from typing import Iterator

import numpy as np

from .parallel import map_ahead

_LITTLE_ENDIAN = 1
_Z = 0x80000000
_POLYGON, _MULTIPOLYGON = 3, 6


#: Faces whose polygons are made at a time (:func:`multipolygons_z`): a few
#: MB of records that stay in the cache. The 1 km synthetic city's 3.6 M
#: block triangles at once took 390 MB of records, and as much again in
#: bytes; its blocks' WKB took 1.3 s that way, 1.0 s a chunk at a time.
CHUNK_FACES = 65536


def multipolygons_z(nodes: np.ndarray, faces: np.ndarray, group: np.ndarray, n_groups: int,
                    offset: np.ndarray | None = None) -> Iterator[bytes]:
    """WKB of ``n_groups`` MultiPolygonZ, group ``g`` made of the faces
    ``group == g``, one after the other.

    The polygons are made for about :data:`CHUNK_FACES` faces at a time (at
    least one group), as the caller takes the multipolygons: a writer holds
    one group's bytes at a time, not a city's, while the threads make the
    next chunks, at most two each ahead (:func:`core.parallel.map_ahead`;
    the 1 km city's blocks layer 0.71-0.74 -> 0.67-0.71 s, its ground
    layer 0.49-0.56 -> 0.48-0.53 s with nothing else to do meanwhile).

    Parameters
    ----------
    nodes : ndarray of float (N, 3)
    faces : ndarray of int (F, K)
        One single-ring polygon each: its corners, then the first again.
    group : ndarray of int (F,)
        The multipolygon of each face, ascending.
    n_groups : int
    offset : ndarray (3,), optional
        Added to the coordinates of the faces' corners as the chunks gather
        them, on the threads: world coordinates from a grid's local nodes,
        without a copy of every node on one core first (the 1 km city's
        4.8 M nodes: 0.05-0.07 s for each layer). The same numbers.

    Yields
    ------
    bytes
        One WKB per group, its polygons in the order of ``faces``.

    Examples
    --------
    >>> import shapely
    >>> nodes = np.array([[0, 0, 1], [1, 0, 1], [0, 1, 1], [2, 2, 3.0]])
    >>> faces = np.array([[0, 1, 2], [1, 3, 2]])
    >>> rings = nodes[np.concatenate([faces, faces[:, :1]], axis=1)]
    >>> wkb = list(multipolygons_z(nodes, faces, np.array([0, 0]), 1))
    >>> wkb[0] == shapely.to_wkb(shapely.multipolygons(shapely.polygons(rings)), output_dimension=3)
    True
    """
    k = faces.shape[1]
    # Each polygon: byte order, type, one ring, its K + 1 points; then the
    # coordinates, unaligned after those 13 bytes.
    prefix = np.array([(_LITTLE_ENDIAN, _Z | _POLYGON, 1, k + 1)],
                      dtype=[("order", "u1"), ("type", "<u4"), ("rings", "<u4"), ("points", "<u4")])
    prefix = prefix.view(np.uint8)
    size = prefix.size + 24 * (k + 1)
    header = np.dtype([("order", "u1"), ("type", "<u4"), ("count", "<u4")])
    bounds = np.searchsorted(group, np.arange(n_groups + 1))
    # Chunks of whole groups, about CHUNK_FACES faces each (at least one group).
    chunks, first = [], 0
    while first < n_groups:
        stop = min(n_groups, max(first + 1, int(np.searchsorted(bounds, bounds[first] + CHUNK_FACES, "right")) - 1))
        chunks.append((first, stop))
        first = stop

    def records_of(chunk: tuple[int, int]) -> np.ndarray:
        """The polygons of a chunk's faces, as bytes in a row each."""
        faces_of = faces[bounds[chunk[0]]:bounds[chunk[1]]]
        # The closed rings' coordinates in a table of their own (aligned, so
        # the gathers run at full speed), then copied after the prefixes.
        xyz = np.empty((len(faces_of), k + 1, 3))
        for corner in range(k):
            xyz[:, corner] = nodes.take(faces_of[:, corner], axis=0)  # take: faster rows (core.vectors)
        if offset is not None:
            xyz[:, :k] += offset
        xyz[:, k] = xyz[:, 0]
        records = np.empty((len(faces_of), size), np.uint8)
        records[:, :prefix.size] = prefix
        records[:, prefix.size:] = xyz.view(np.uint8).reshape(len(faces_of), size - prefix.size)
        return records.reshape(-1)

    # The chunks are made on the threads ahead of the caller (core.parallel):
    # a GIS writer parses and writes one while the next ones are made.
    for (first, stop), records in zip(chunks, map_ahead(records_of, chunks)):
        for g in range(first, stop):
            head = np.array([(_LITTLE_ENDIAN, _Z | _MULTIPOLYGON, bounds[g + 1] - bounds[g])], dtype=header)
            start = (bounds[g] - bounds[first]) * size
            # One copy of the records (join takes the memory as it is).
            yield b"".join((head.tobytes(), memoryview(records[start:start + (bounds[g + 1] - bounds[g]) * size])))
