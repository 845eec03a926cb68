"""The compiled choice of the data points a node tries
(core.projection_kernel) against numpy's (core.project): the same points."""
import numpy as np
import pytest

from core.project import _distance_to_line, _ranked


@pytest.fixture
def kernel(compiled):
    return compiled("projection_kernel")


def numpy_choice(data, near, p, normal, tries):
    off_line = _distance_to_line(data, near, p, normal)
    return np.take_along_axis(near, _ranked(off_line, near, data, tries), axis=1)


@pytest.mark.parametrize("k,tries", [(24, 3), (4, 3), (3, 3), (2, 3), (24, 1)])
def test_same_points_as_numpy_with_ties_and_missing_neighbours(kernel, k, tries):
    rng = np.random.default_rng(k + tries)
    # Data on a half-voxel lattice, with duplicates: many points at equal
    # distances from nodes on the lattice with axis-aligned normals.
    data = np.round(rng.uniform(0, 20, (4000, 3)) * 2) / 2
    data = np.concatenate([data, data[:300]])
    q = 20_000
    p = np.round(rng.uniform(0, 20, (q, 3)) * 2) / 2
    normal = np.eye(3)[rng.integers(0, 3, q)] * rng.choice([-1.0, 1.0], (q, 1))
    tilted = rng.random(q) < 0.3
    normal[tilted] = rng.normal(size=(tilted.sum(), 3))
    normal[tilted] /= np.linalg.norm(normal[tilted], axis=1, keepdims=True)
    normal[rng.random(q) < 0.02] = 0.0  # unusable nodes are ranked too
    near = rng.integers(0, len(data), (q, k))
    near[rng.random((q, k)) < 0.15] = len(data)  # missing neighbours
    expected = numpy_choice(data, near, p, normal, tries)
    got = kernel.closest_to_lines(data, near, p, normal, tries)
    assert got.shape == expected.shape and np.array_equal(got, expected)


@pytest.mark.parametrize("k,tries,radius", [(24, 3, 1.5), (24, 3, 1.0), (5, 3, 2.0), (2, 3, 1.5), (24, 1, 1.5)])
def test_fused_search_chooses_the_points_of_the_two_steps(kernel, k, tries, radius):
    """The k nearest within the radius then the few closest to the line, in
    one pass (the projection's step 1 with numba), against the index's
    nearest points then :func:`closest_to_lines` (each tested against the
    KD-tree and numpy): the same point numbers. Lattice data with
    duplicates put many points at exactly the radius (left out) and at
    equal distances, from the node and from the line."""
    from core.neighbours_kernel import ColumnIndex

    rng = np.random.default_rng(k + 10 * tries)
    data = np.round(rng.uniform(0, 12, (6000, 3)) * 2) / 2
    data = np.concatenate([data, data[:500]])
    q = 10_000
    p = np.round(rng.uniform(-1, 13, (q, 3)) * 2) / 2
    normal = np.eye(3)[rng.integers(0, 3, q)] * rng.choice([-1.0, 1.0], (q, 1))
    tilted = rng.random(q) < 0.3
    normal[tilted] = rng.normal(size=(tilted.sum(), 3))
    normal[tilted] /= np.linalg.norm(normal[tilted], axis=1, keepdims=True)
    p[-50:] += 100.0  # nodes with no point within the radius
    for cell in (0.7, 1.5 * radius, 5.0):
        index = ColumnIndex(data, cell)
        expected = kernel.closest_to_lines(data, index.nearest(p, k, radius)[1], p, normal, tries)
        # The first radius from the density, and others: most nodes then
        # have more than k points inside it, about half (so the search
        # switches to the whole radius and back), or all or none; on this
        # lattice many points lie at exactly 0.5 and 1.0.
        for near in (None, 0.3, 0.5, 0.8, 1.0, radius):
            got = kernel.candidates_near_lines(index, p, normal, k, radius, tries, near)
            assert got.shape == expected.shape and np.array_equal(got, expected), near
    assert (expected[-50:] == len(data)).all() and (expected[:-50, 0] < len(data)).mean() > 0.8


def test_fused_search_chooses_the_points_of_numpy_from_a_kd_tree(kernel):
    """Against the projection's numpy steps on surfaces sampled at random (no ties)."""
    from core.neighbours import nearest, search_tree
    from core.neighbours_kernel import ColumnIndex

    rng = np.random.default_rng(4)
    xy = rng.uniform(0, 30, (20_000, 2))
    data = np.column_stack([xy, np.where(xy[:, 0] > 15, 6.0, 0.0) + 0.05 * rng.normal(size=len(xy))])
    p = data[rng.integers(0, len(data), 8000)] + rng.normal(scale=0.4, size=(8000, 3))
    normal = rng.normal(size=(8000, 3)) + [0, 0, 3]
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    expected = numpy_choice(data, nearest(search_tree(data), data, p, 24, 1.5)[1], p, normal, 3)
    for near in (None, 0.5, 0.9):
        got = kernel.candidates_near_lines(ColumnIndex(data, 1.5), p, normal, 24, 1.5, 3, near)
        assert np.array_equal(got, expected), near


def test_fused_search_stops_at_a_cancel_between_blocks(kernel, monkeypatch):
    # All the nodes come in one call (core.project._candidates): its blocks
    # check for a cancel, on the pool's threads or here. The first block
    # passes the check, a later one is cancelled.
    from core.errors import Cancelled
    from core.neighbours_kernel import ColumnIndex

    rng = np.random.default_rng(2)
    data = np.column_stack([rng.uniform(0, 40, (20_000, 2)), rng.normal(0, 0.05, 20_000)])
    p = data[rng.integers(0, len(data), 3 * kernel._BLOCK)] + [0, 0, 0.3]
    normal = np.tile([0.0, 0, 1], (len(p), 1))
    index = ColumnIndex(data, 1.5)
    for threads in ("1", "2"):
        monkeypatch.setenv("URBANVOX_THREADS", threads)
        asked = []
        with pytest.raises(Cancelled):
            kernel.candidates_near_lines(index, p, normal, 24, 1.5, 3, None, lambda: asked.append(1) or len(asked) > 1)
    found = kernel.candidates_near_lines(index, p, normal, 24, 1.5, 3, None, lambda: False)
    assert np.array_equal(found, kernel.candidates_near_lines(index, p, normal, 24, 1.5, 3))
    assert (found < len(data)).all()


def test_fused_search_on_fewer_points_than_asked(kernel):
    from core.neighbours_kernel import ColumnIndex

    data = np.array([[3.0, 4.0, 7.0], [0.0, 0.0, -2.0], [0.0, 1.0, 5.0]])
    got = kernel.candidates_near_lines(ColumnIndex(data, 1.0), np.zeros((2, 3)), np.array([[0, 0, 1.0]] * 2),
                                       24, 10.0, 5)
    assert got.tolist() == [[1, 2, 0]] * 2  # min(tries, k, len(data)) columns, all found


def test_rows_with_ties_are_ordered_by_coordinates(kernel):
    # Four points at the same distance from the vertical line: x, then y, then z decide.
    data = np.array([[1.0, 0, 5], [0, 1, 2], [0, -1, 3], [-1, 0, 4], [0, 1, 1]])
    near = np.array([[0, 1, 2, 3, 4]])
    got = kernel.closest_to_lines(data, near, np.zeros((1, 3)), np.array([[0, 0, 1.0]]), 4)
    assert got.tolist() == [[3, 2, 4, 1]]
    assert np.array_equal(got, numpy_choice(data, near, np.zeros((1, 3)), np.array([[0, 0, 1.0]]), 4))


def test_distances_to_the_line_are_numpys_bit_for_bit(kernel):
    import numba

    @numba.njit
    def every(data, near, p, normal):
        out = np.empty(near.shape)
        for q in range(near.shape[0]):
            for j in range(near.shape[1]):
                x = data[near[q, j]]
                out[q, j] = kernel._off_line(x[0], x[1], x[2], p[q, 0], p[q, 1], p[q, 2],
                                             normal[q, 0], normal[q, 1], normal[q, 2])
        return out

    rng = np.random.default_rng(9)
    data = rng.uniform(-3000, 3000, (5000, 3))
    p = data[rng.integers(0, 5000, 20_000)] + rng.normal(scale=2.0, size=(20_000, 3))
    normal = rng.normal(size=(20_000, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    near = rng.integers(0, 5000, (20_000, 24))
    assert np.array_equal(every(data, near, p, normal), _distance_to_line(data, near, p, normal))
