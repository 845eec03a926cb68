"""The compiled column index (core.neighbours_kernel) against the KD-tree
search it stands in for (core.neighbours.nearest): the same neighbours."""
import numpy as np
import pytest

from core.neighbours import nearest, search_tree


@pytest.fixture
def kernel(compiled):
    return compiled("neighbours_kernel")


def both(kernel, data, at, k, upper=np.inf, cell=1.0):
    expected = nearest(search_tree(data), data, at, k, upper)
    got = kernel.ColumnIndex(data, cell).nearest(at, k, upper)
    return expected, got


def assert_same(data, expected, got):
    """Same distances to the last bit, same points (by coordinates: points
    that share them may come in another order of their indices)."""
    assert got[0].shape == expected[0].shape and got[1].dtype == expected[1].dtype
    assert np.array_equal(got[0], expected[0])
    found = expected[1] < len(data)
    assert np.array_equal(found, got[1] < len(data))
    assert np.array_equal(data[got[1][found]], data[expected[1][found]])


@pytest.mark.parametrize("k,upper", [(24, 1.5), (12, np.inf), (1, np.inf), (3, 0.5)])
def test_same_neighbours_as_the_kd_tree_on_surfaces(kernel, k, upper):
    # A ground and walls, as city data: points spread over surfaces, and
    # queries near and far from them (unbounded searches widen).
    rng = np.random.default_rng(k)
    ground = np.column_stack([rng.uniform(0, 60, 20_000), rng.uniform(0, 60, 20_000), rng.normal(0, 0.05, 20_000)])
    wall = np.column_stack([np.full(5000, 30.0), rng.uniform(10, 20, 5000), rng.uniform(0, 15, 5000)])
    data = np.concatenate([ground, wall])
    at = np.concatenate([data[rng.integers(0, len(data), 5000)] + rng.normal(scale=0.5, size=(5000, 3)),
                         rng.uniform(-20, 80, (500, 3)) + [0, 0, 30]])
    assert_same(data, *both(kernel, data, at, k, upper))


def brute_force(data, at, k, upper):
    """The k nearest by (distance, x, y, z), within ``upper`` as scipy has it
    (squared distance below ``upper * upper``), with scipy's distances."""
    diff = [data[None, :, c] - at[:, None, c] for c in range(3)]
    squared = (diff[0] * diff[0] + diff[1] * diff[1]) + diff[2] * diff[2]
    order = np.lexsort((np.broadcast_to(data[:, 2], squared.shape), np.broadcast_to(data[:, 1], squared.shape),
                        np.broadcast_to(data[:, 0], squared.shape), np.sqrt(squared)), axis=1)[:, :k]
    near = np.take_along_axis(squared, order, axis=1)
    within = near < upper * upper  # as scipy: sqrt(2) is within sqrt(2), 2 < sqrt(2) ** 2
    return np.where(within, np.sqrt(near), np.inf), np.where(within, order, len(data))


@pytest.mark.parametrize("k,upper", [(24, 1.5), (12, np.inf), (8, 1.0), (5, np.sqrt(2))])
def test_ties_on_a_lattice_and_points_on_the_bound(kernel, k, upper):
    # Data and queries on a lattice, with duplicates: rings of points at
    # equal distances, and points exactly at the bound (excluded, as scipy
    # excludes them). The index is exact; the KD-tree search asks for eight
    # more points where the k-th place is tied, and misses a few rows where
    # more share it (core.neighbours.nearest).
    rng = np.random.default_rng(7)
    data = np.round(rng.uniform(0, 12, (3000, 3)) * 2) / 2
    at = np.round(rng.uniform(0, 12, (1500, 3)) * 2) / 2
    got = kernel.ColumnIndex(data, 0.75).nearest(at, k, upper)
    assert_same(data, brute_force(data, at, k, upper), got)
    tree = nearest(search_tree(data), data, at, k, upper)
    assert np.array_equal(tree[0], got[0])
    same_points = (data[np.minimum(tree[1], len(data) - 1)] == data[np.minimum(got[1], len(data) - 1)]).all(axis=(1, 2))
    assert same_points.mean() > 0.95


def test_nearest_of_queries_far_above_a_lattice(kernel):
    # One nearest, unbounded, from high above a sparse lattice (wall nodes
    # under roof points): the search widens several times and stops at the
    # distance of a point already seen, where others on the lattice tie.
    rng = np.random.default_rng(11)
    data = np.array([(x, y, 0.0) for x in range(0, 40, 2) for y in range(0, 40, 2)], dtype=float)
    at = np.column_stack([np.round(rng.uniform(0, 38, 400)), np.round(rng.uniform(0, 38, 400)),
                          rng.integers(1, 12, 400).astype(float)])
    got = kernel.ColumnIndex(data, 0.75).nearest(at, 1)
    expected = brute_force(data, at, 1, np.inf)
    assert np.isfinite(got[0]).all() and got[0].max() > 5  # some searched far
    assert_same(data, expected, got)


def test_bound_decided_as_scipy_decides_it(kernel):
    # Distances a hair either side of the bound, in city coordinates.
    rng = np.random.default_rng(3)
    at = rng.uniform(-3000, 3000, (20_000, 3))
    direction = rng.normal(size=(20_000, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    data = at + direction * (1.0 + rng.integers(-3, 4, (20_000, 1)) * 1e-15)
    tree = search_tree(data)
    d, i = tree.query(at, k=1, distance_upper_bound=1.0)
    got_d, got_i = kernel.ColumnIndex(data, 1.0).nearest(at, 1, 1.0)
    assert 1000 < np.isinf(d).sum() < 19_000
    assert np.array_equal(got_d[:, 0], d) and np.array_equal(got_i[:, 0], i)


def test_fewer_points_than_asked_and_no_queries(kernel):
    data = np.array([[0.0, 0, 0], [1, 0, 0], [0, 3, 0]])
    index = kernel.ColumnIndex(data, 1.0)
    dist, idx = index.nearest(np.array([[0.0, 0, 0.5]]), 5)
    assert idx.tolist() == [[0, 1, 2]] and dist.shape == (1, 3)
    dist, idx = index.nearest(np.array([[0.0, 0, 0]]), 3, upper=2.0)
    assert idx.tolist() == [[0, 1, 3]] and dist[0, 2] == np.inf
    assert index.nearest(np.zeros((0, 3)), 2)[0].shape == (0, 2)


def test_sparse_data_over_a_wide_extent_get_wider_columns(kernel):
    # 50 points over 100 km: the grid stays small, the answers the same.
    rng = np.random.default_rng(2)
    data = rng.uniform(0, 100_000, (50, 3))
    index = kernel.ColumnIndex(data, 1.0)
    assert index.nx * index.ny <= 1 << 17
    at = rng.uniform(0, 100_000, (200, 3))
    assert_same(data, nearest(search_tree(data), data, at, 4), index.nearest(at, 4))


@pytest.mark.parametrize("k", [5, 8, 24])
def test_square_roots_tie_where_squared_distances_do_not(kernel, k):
    # A search skips the points beyond the k-th squared distance so far by
    # more than a margin for round-off: a point at squared distance
    # 1 + 2^-52 has distance 1.0, as one at squared distance 1, and comes
    # first by its smaller x. Around each query, k - 1 points nearer, then
    # these two (exact in binary), then farther ones.
    rng = np.random.default_rng(k)
    at = np.array([[64.0 * i, 64.0 * j, 0.0] for i in range(5) for j in range(5)])
    tied = np.array([[1.0, 0, 0], [2.0**-26, 1, 0]])  # squared: 1 and 1 + 2^-52
    assert (tied**2).sum(axis=1)[1] > 1.0 and np.sqrt((tied**2).sum(axis=1))[1] == 1.0
    nearer, farther = rng.normal(size=(2, len(at), k - 1, 3))
    nearer *= rng.uniform(0.1, 0.9, (len(at), k - 1, 1)) / np.linalg.norm(nearer, axis=2, keepdims=True)
    farther *= rng.uniform(1.1, 1.4, (len(at), k - 1, 1)) / np.linalg.norm(farther, axis=2, keepdims=True)
    data = (at[:, None, :] + np.concatenate([nearer, np.broadcast_to(tied, (len(at), 2, 3)), farther], axis=1)
            ).reshape(-1, 3)
    got = kernel.ColumnIndex(data, 1.0).nearest(at, k, 1.5)
    assert_same(data, brute_force(data, at, k, 1.5), got)
    assert np.array_equal(data[got[1][:, k - 1]] - at, np.broadcast_to(tied[1], at.shape))


@pytest.mark.parametrize("threads,parallel_points", [("1", 1 << 16), ("3", 10)])
@pytest.mark.parametrize("subset", [False, True])
def test_points_sorted_by_column_then_height_in_their_order_on_every_core(kernel, monkeypatch, threads,
                                                                         parallel_points, subset):
    """by_column on one block and on several (each thread's points put after
    the blocks before it in every column): by column, then by height, ties in
    the order of the points, as a stable sort of (column, height) gives."""
    monkeypatch.setenv("URBANVOX_THREADS", threads)
    monkeypatch.setattr(kernel, "_PARALLEL_POINTS", parallel_points)
    rng = np.random.default_rng(7)
    xyz = np.round(rng.random((5_000, 3)) * [9.0, 7.0, 3.0], 1)  # many equal heights in a column
    xyz[::50] = [-4.0, 20.0, 1.0]  # clipped into a border column, all at one height
    rows = rng.permutation(len(xyz))[:3_000] if subset else np.empty(0, np.int64)
    chosen = rows if subset else np.arange(len(xyz))
    nx, ny = 5, 4
    column = (np.clip(np.floor(xyz[chosen, 0] / 2.0), 0, nx - 1)
              + nx * np.clip(np.floor(xyz[chosen, 1] / 2.0), 0, ny - 1)).astype(np.int64)
    expected = chosen[np.lexsort((xyz[chosen, 2], column))]
    order = np.empty(len(chosen), np.int64)
    start = kernel.by_column(xyz, rows, 0.0, 0.0, 2.0, nx, ny, order)
    assert np.array_equal(order, expected)
    assert np.array_equal(start, np.concatenate([[0], np.cumsum(np.bincount(column, minlength=nx * ny))]))


@pytest.mark.parametrize("k,upper", [(1, np.inf), (12, np.inf), (24, 1.5)])
def test_index_of_the_first_points_answers_as_a_new_index(kernel, k, upper):
    # The pipeline's ground points, then the ground levels under the roofs at
    # column centres, beyond the ground points' extent: the index of the
    # ground points taken from the index of both finds what an index made
    # over the ground points alone finds (ties on a lattice, by index too).
    rng = np.random.default_rng(k)
    ground = np.round(rng.uniform(0, 30, (4000, 3)) * 4) / 4
    under_roofs = np.column_stack([rng.uniform(-10, 40, 1500), rng.uniform(-10, 40, 1500), rng.uniform(0, 3, 1500)])
    both_index = kernel.ColumnIndex(np.concatenate([ground, under_roofs]), 0.75)
    first = both_index.of_first(ground)
    assert (first.x0, first.y0) != tuple(ground[:, :2].min(axis=0))  # the other grid: not a copy of a new index
    at = np.concatenate([ground[rng.integers(0, len(ground), 1500)] + rng.normal(scale=0.4, size=(1500, 3)),
                         rng.uniform(-15, 45, (300, 3)) + [0, 0, 10]])
    got = first.nearest(at, k, upper)
    expected = kernel.ColumnIndex(ground, 0.75).nearest(at, k, upper)
    assert np.array_equal(got[0], expected[0]) and np.array_equal(got[1], expected[1])
    assert np.array_equal(got[0], brute_force(ground, at, k, upper)[0])
    assert first.n == len(ground) and (got[1] <= len(ground)).all()
    with pytest.raises(ValueError):
        first.of_first(np.concatenate([ground, ground]))
