"""Neighbour searches: answers independent of the search tree, against brute force."""
import numpy as np
import pytest
from scipy.spatial import cKDTree

from core.neighbours import nearest, nearest_distance, search_tree
from core.parallel import in_background


def _brute_force(data, at, k):
    """The k nearest by (distance, x, y, z), from every distance."""
    dist = np.linalg.norm(data[None, :, :] - at[:, None, :], axis=2)
    order = np.array([np.lexsort((data[:, 2], data[:, 1], data[:, 0], row))[:k] for row in dist])
    return np.take_along_axis(dist, order, axis=1), order


def test_nearest_breaks_ties_by_coordinates_whatever_the_tree():
    # A lattice: every query point (at a lattice point or a cell centre) has
    # many neighbours at exactly the same distance.
    axis = np.arange(6, dtype=float)
    data = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)
    at = np.concatenate([data[::17], data[::23] + 0.5])
    want_dist, want_idx = _brute_force(data, at, 6)
    shuffled = np.random.default_rng(0).permutation(len(data))
    for tree, points, index in ((search_tree(data), data, np.arange(len(data))),
                                (cKDTree(data), data, np.arange(len(data))),
                                (search_tree(data[shuffled]), data[shuffled], shuffled)):
        dist, idx = nearest(tree, points, at, 6)
        np.testing.assert_array_equal(index[idx], want_idx)
        np.testing.assert_allclose(dist, want_dist, rtol=1e-15)


def test_nearest_marks_missing_neighbours_beyond_the_bound():
    data = np.array([[0.0, 0, 0], [1, 0, 0], [5, 0, 0]])
    dist, idx = nearest(search_tree(data), data, np.array([[0.2, 0, 0]]), 3, upper=2.0)
    assert idx[0].tolist() == [0, 1, 3]
    assert dist[0, 2] == np.inf
    assert dist[0, :2] == pytest.approx([0.2, 0.8])


def test_nearest_distance_over_several_trees_matches_brute_force_over_their_union():
    # Two parts of the data (buildings and ground): the second tree is first
    # searched within a bound, then within each point's distance so far.
    rng = np.random.default_rng(1)
    data, points = rng.random((500, 3)) * 10, rng.random((200, 3)) * 12
    want = np.linalg.norm(points[:, None] - data[None], axis=2).min(axis=1)
    for split in (0, 1, 250, 499, 500):
        for bound in (0.0, 0.3, 1.0, 100.0):
            trees = [search_tree(data[:split]), search_tree(data[split:])]
            np.testing.assert_array_equal(nearest_distance(points, trees, bound), want)
    # The second tree still being made on the background thread (the pipeline's ground search).
    later = in_background(search_tree, data[250:])
    np.testing.assert_array_equal(nearest_distance(points, [search_tree(data[:250]), later], 0.3), want)
    assert np.isnan(nearest_distance(points, [search_tree(data[:0])], 1.0)).all()


def test_compiled_searches_bounded_by_the_distance_so_far_find_the_same_distances(compiled):
    """The second index's searches go no farther than each point's distance
    so far (its own bound, core.neighbours_kernel): the minimum over both
    stays the brute-force one, ties at that distance included."""
    from core.neighbours import point_index

    kernel = compiled("neighbours_kernel")
    rng = np.random.default_rng(4)
    data = np.round(rng.random((600, 3)) * 10, 1)  # points at equal distances from lattice queries
    points = np.concatenate([np.round(rng.random((300, 3)) * 12, 1), rng.random((100, 3)) * 40 - 15])
    want = np.linalg.norm(points[:, None] - data[None], axis=2).min(axis=1)
    for split in (1, 300, 599):
        for bound in (0.0, 0.3, 1.0, 100.0):
            indexes = [point_index(data[:split], 1.0), point_index(data[split:], 1.0)]
            assert isinstance(indexes[1], kernel.ColumnIndex)
            np.testing.assert_array_equal(nearest_distance(points, indexes, bound), want)
    # A bound per point: each point's nearest strictly within its own bound, else none.
    index = kernel.ColumnIndex(data, 1.0)
    bounds = rng.random(len(points)) * 3
    got = index.nearest(points, 1, bounds)[0][:, 0]
    each = np.array([index.nearest(p[None], 1, b)[0][0, 0] for p, b in zip(points, bounds)])
    np.testing.assert_array_equal(got, each)
    assert np.isfinite(got).any() and np.isinf(got).any()
    np.testing.assert_array_equal(got, np.where(want < bounds, want, np.inf))


def test_nearest_distance_skips_only_points_with_nothing_that_near():
    # Building points above ground points on a 1 m grid of columns: the
    # ground's searches skip the points higher above the ground's ceiling
    # than the distance searched (core.ground.NearGround), and the
    # distances stay those of a search over everything.
    from core.grid import VoxelGrid
    from core.ground import NearGround

    rng = np.random.default_rng(3)
    grid = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (20, 20, 30))
    ground = np.column_stack([rng.random((3000, 2)) * 20, 2 + 0.05 * rng.standard_normal(3000)])
    building = np.column_stack([rng.random((300, 2)) * 20, 4 + 20 * rng.random(300)])
    points = np.column_stack([rng.random((2000, 2)) * 24 - 2, 30 * rng.random(2000)])
    want = np.linalg.norm(points[:, None] - np.concatenate([building, ground])[None], axis=2).min(axis=1)
    near_ground = NearGround(grid, ground)
    assert (near_ground(points, 1.0).mean()) < 0.2  # most points skip the first search
    trees = [search_tree(building), search_tree(ground)]
    np.testing.assert_array_equal(nearest_distance(points, trees, 1.0, [None, near_ground]), want)


class _CountingTree(cKDTree):
    """A KD-tree that records the ``workers`` of its queries."""

    def query(self, *args, **kwargs):
        self.workers.append(kwargs.get("workers", 1))
        return super().query(*args, **kwargs)


def test_queries_take_the_threads_they_are_given(monkeypatch):
    """A Dask worker's share of the cores (URBANVOX_THREADS), not every core;
    one thread inside the row-block pool (the MLS planes), all of them when a
    single block runs outside it; one for a small search (scipy starts its
    threads at every call)."""
    from core.mls import mls_planes

    data = np.random.default_rng(3).uniform(0, 10, (5000, 3))
    tree = _CountingTree(data)
    tree.workers = []
    monkeypatch.setenv("URBANVOX_THREADS", "1")
    nearest(tree, data, data[:3000], 5)
    nearest_distance(data[:3000] + 0.1, [tree], 1.0)
    assert tree.workers and set(tree.workers) == {1}
    monkeypatch.setenv("URBANVOX_THREADS", "3")
    tree.workers = []
    nearest(tree, data, data[:3000], 5)  # 15,000 neighbours
    assert set(tree.workers) == {3}
    tree.workers = []
    nearest(tree, data, data[:100], 5)  # 500: on this thread
    nearest_distance(data[:100] + 0.1, [tree], 1.0)
    assert set(tree.workers) == {1}
    tree.workers = []
    mls_planes(data, tree, np.tile(data, (8, 1)), 0.5)  # 40,000 planes: several blocks, on the pool's threads
    assert set(tree.workers) == {1}
    tree.workers = []
    mls_planes(data, tree, data[:2000], 0.5)  # one block, run here
    assert set(tree.workers) == {3}
