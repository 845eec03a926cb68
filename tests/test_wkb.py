"""MultiPolygonZ WKB written by numpy (core.wkb) against shapely's, a chunk of faces at a time."""

import numpy as np
import pytest
import shapely

from core import wkb as wkb_module
from core.wkb import multipolygons_z


def expected(nodes, faces):
    """shapely's WKB of the faces as one MultiPolygonZ (the reference)."""
    if len(faces) == 0:  # shapely writes an empty multipolygon without its Z flag
        return bytes([1]) + (0x80000006).to_bytes(4, "little") + (0).to_bytes(4, "little")
    rings = nodes[np.concatenate([faces, faces[:, :1]], axis=1)]
    return shapely.to_wkb(shapely.multipolygons(shapely.polygons(rings)), output_dimension=3)


@pytest.mark.parametrize("corners", [3, 4])
@pytest.mark.parametrize("chunk", [1, 5, 8, 65536])
def test_groups_across_chunks_are_shapelys_bytes(monkeypatch, corners, chunk):
    # Groups of 0 to 12 faces (empty ones first, last and between), made 1, 5
    # or 8 faces at a time (a group larger than a chunk is made whole) or
    # all at once: each multipolygon is shapely's, in the order of the faces.
    monkeypatch.setattr(wkb_module, "CHUNK_FACES", chunk)
    rng = np.random.default_rng(corners)
    nodes = rng.random((40, 3)) * [100.0, 100.0, 20.0] + [5e5, 6e6, 0.0]
    sizes = [0, 3, 7, 1, 0, 12, 2, 0]
    faces = rng.integers(0, 40, (sum(sizes), corners))
    group = np.repeat(np.arange(len(sizes)), sizes)
    made = multipolygons_z(nodes, faces, group, len(sizes))
    starts = np.concatenate([[0], np.cumsum(sizes)])
    wanted = [expected(nodes, faces[starts[g]:starts[g + 1]]) for g in range(len(sizes))]
    assert list(made) == wanted
    # Local nodes and the offset added as the chunks gather them: the same bytes.
    offset = np.array([5e5, 6e6, 0.0])
    local = nodes - offset
    wanted = [expected(local + offset, faces[starts[g]:starts[g + 1]]) for g in range(len(sizes))]
    assert list(multipolygons_z(local, faces, group, len(sizes), offset=offset)) == wanted


def test_nothing_to_write_makes_nothing():
    assert list(multipolygons_z(np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros(0, np.int64), 0)) == []


def test_the_multipolygons_are_made_as_they_are_taken(monkeypatch):
    # A writer holds a few chunks' records, not a city's: on one thread, the
    # second chunk is not made before the first chunk's groups are taken; on
    # more, the threads make at most two chunks each ahead of the writer.
    monkeypatch.setattr(wkb_module, "CHUNK_FACES", 4)
    gathered = []
    nodes = np.arange(30.0).reshape(10, 3)

    class Nodes(np.ndarray):
        def take(self, indices, axis=None):
            gathered.append(len(indices))
            return np.asarray(self).take(indices, axis=axis)

    faces = np.arange(24).reshape(8, 3) % 10
    monkeypatch.setenv("URBANVOX_THREADS", "1")
    made = multipolygons_z(nodes.view(Nodes), faces, np.repeat(np.arange(4), 2), 4)
    next(made)
    assert gathered == [4, 4, 4]  # the first chunk's three corners: two groups of two faces
    next(made)
    assert gathered == [4, 4, 4]
    assert len(list(made)) == 2 and gathered == [4, 4, 4] * 2
    gathered.clear()
    monkeypatch.setenv("URBANVOX_THREADS", "2")
    many = np.arange(120).reshape(40, 3) % 10
    made = multipolygons_z(nodes.view(Nodes), many, np.repeat(np.arange(20), 2), 20)  # ten chunks
    next(made)
    assert len(gathered) <= 3 * (1 + 2 * 2)
    assert len(list(made)) == 19 and gathered == [4] * 30
