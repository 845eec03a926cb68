"""The compiled crossing search (core.crossing_kernel) against the numpy code
it stands in for (core.intersect): the same crossings, bit for bit."""
import numpy as np
import pytest

from core.intersect import _balls, _Cells, _crossing_quads, _pair_rows
from test_intersect import _reference_edges_cross


@pytest.fixture
def kernel(compiled):
    return compiled("crossing_kernel")


def test_edge_crossings_match_numpys_arithmetic_bit_for_bit(kernel):
    # Near-degenerate pairs at every scale (edges grazing a triangle): the
    # scalar code gives numpy's answers on every pair, not just most.
    import numba

    @numba.njit
    def every_pair(nodes, a, b):
        # The kernel takes two rows of one triangle table.
        both = np.concatenate((a, b))
        hit = np.zeros(len(a), np.bool_)
        for p in range(len(a)):
            hit[p] = kernel._edges_cross(nodes, both, p, len(a) + p)
        return hit

    rng = np.random.default_rng(8)
    nodes = rng.normal(size=(3000, 3)) * 10.0 ** rng.integers(-6, 4, size=(3000, 1))
    tri = rng.integers(0, 3000, size=(200_000, 3))
    a, b = tri[:100_000].copy(), tri[100_000:]
    graze = rng.random(100_000) < 0.5
    w = rng.random((100_000, 3))
    w /= w.sum(axis=1, keepdims=True)
    nodes = np.concatenate([nodes, np.einsum("pk,pkc->pc", w, nodes[b])[graze]])
    a[graze, 0] = 3000 + np.arange(graze.sum())
    expected = _reference_edges_cross(nodes[a], nodes[b])
    assert 0 < expected.sum() < len(a)
    assert np.array_equal(every_pair(nodes, a, b), expected)


def _soup(rng, n, extent, sizes):
    """``n`` random quads (planar parallelograms of several sizes, any
    orientation) scattered over ``extent``; many cross each other."""
    corner = rng.random((n, 3)) * extent
    size = rng.choice(sizes, size=(n, 1)) * rng.uniform(0.5, 1.0, (n, 1))
    u, v = rng.normal(size=(2, n, 3))
    u *= size / np.linalg.norm(u, axis=1, keepdims=True)
    v *= size / np.linalg.norm(v, axis=1, keepdims=True)
    nodes = np.stack([corner, corner + u, corner + u + v, corner + v], axis=1).reshape(-1, 3)
    return nodes, np.arange(4 * n).reshape(n, 4)


def _crossings(positions, quads, moved, seeds, near=None):
    """The crossing triangle pairs of one round: a set of pairs of node
    triples, each pair in order (which comes first is the search's order
    where both triangles are in focus)."""
    centre, reach = _balls(positions, quads)
    diagonal, split = np.zeros(len(quads), bool), np.zeros(len(quads), bool)
    cells = _Cells(centre, 2 * reach.max())
    pairs = _crossing_quads(positions, quads, diagonal, split, centre, reach, seeds, moved, near, cells, 16, None)
    return {tuple(sorted(map(tuple, p))) for p in pairs.tolist()}


@pytest.mark.parametrize("extent,sizes", [((6, 6, 2), [0.3, 1.0, 3.0]),    # three size classes
                                          ((2000, 2000, 5), [1.0]),          # scattered: a wider grid
                                          ((20, 0.5, 20), [0.5, 0.6])])      # a wall, one tier in effect
def test_same_crossings_as_the_numpy_search(monkeypatch, kernel, extent, sizes):
    rng = np.random.default_rng(3)
    found = []
    for trial in range(4):
        positions, quads = _soup(rng, 400, extent, sizes)
        moved = rng.random(len(positions)) < [1.0, 0.3, 0.05, 0.5][trial]
        seeds = np.flatnonzero(moved[quads].any(axis=1))
        near = None if trial < 3 else (positions.min(axis=0), positions.min(axis=0) + 0.5 * np.array(extent))
        monkeypatch.setenv("URBANVOX_JIT", "0")
        expected = _crossings(positions, quads, moved, seeds, near)
        monkeypatch.setenv("URBANVOX_JIT", "1")
        assert _crossings(positions, quads, moved, seeds, near) == expected
        found.append(len(expected))
    if extent[0] < 100:  # crowded: crossings in most trials
        assert sum(n > 0 for n in found) >= 3


def test_empty_seeds_find_nothing(kernel):
    positions, quads = _soup(np.random.default_rng(0), 10, (3, 3, 3), [1.0])
    centre, reach = _balls(positions, quads)
    tri = np.arange(2 * len(quads) * 3).reshape(-1, 3) % len(positions)
    pairs = kernel.crossing_triangles(centre, reach, np.zeros(0, np.int64), tri, positions,
                                      _pair_rows(positions, tri), np.ones(len(tri), bool))
    assert pairs.shape == (0, 2)


@pytest.mark.parametrize("dtype", [np.int64, np.int32])
def test_balls_and_boxes_are_numpys_to_the_last_bit(monkeypatch, kernel, dtype):
    # Coordinates at every scale and 2 km from the origin (float32 boxes
    # rounded outwards), a few NaN, triangles and quads.
    rng = np.random.default_rng(12)
    nodes = rng.normal(size=(5000, 3)) * 10.0 ** rng.integers(-6, 4, size=(5000, 1)) + 2000.0
    nodes[:5, 1] = np.nan
    for corners in (3, 4):
        faces = rng.integers(0, len(nodes), size=(100_000, corners)).astype(dtype)
        with monkeypatch.context() as patch:
            patch.setenv("URBANVOX_JIT", "0")
            expected_balls = _balls(nodes, faces)
            expected_boxes = _pair_rows(nodes, faces[:, :3]) if corners == 3 else None
        got = kernel.face_balls(nodes, faces)
        for e, g in zip(expected_balls, got):
            assert g.dtype == e.dtype and np.array_equal(g, e, equal_nan=True)
        if expected_boxes is not None:
            boxes = kernel.triangle_boxes(nodes, faces)
            for e, g in zip(expected_boxes, boxes):
                assert g.dtype == e.dtype == np.float32 and np.array_equal(g, e, equal_nan=True)
            assert np.isnan(boxes[0]).any()
            # Rounded outwards: each box holds its triangle.
            x = nodes[faces]  # (T, 3 corners, 3 axes)
            ok = ~np.isnan(x).any(axis=(1, 2))
            assert (boxes[0].T[ok] <= x[ok].min(axis=1)).all() and (boxes[1].T[ok] >= x[ok].max(axis=1)).all()
