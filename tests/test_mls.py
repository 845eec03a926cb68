"""Moving-least-squares planes (core.mls): the weighted moments against their
former einsum and BLAS formulation, the compiled pass (core.mls_kernel)
against numpy's, and planes fitted to data with a known plane."""
import numpy as np
import pytest

from core.mls import PLANE_POINTS, least_axis, mls_planes, weighted_moments
from core.neighbours import point_index, search_tree


def random_rows(seed: int, n_rows: int = 5_000, k: int = PLANE_POINTS, n_points: int = 20_000):
    """Data around 1 km from the origin (a city's local frame), rows of k points and weights summing to one."""
    rng = np.random.default_rng(seed)
    data = rng.random((n_points, 3)) * [40.0, 30.0, 12.0] + [980.0, 1020.0, 35.0]
    idx = rng.integers(0, n_points, size=(n_rows, k))
    w = np.exp(-rng.random((n_rows, k)) * 4)
    w /= w.sum(axis=1, keepdims=True)
    return data, idx, w


@pytest.mark.parametrize("seed", range(3))
def test_moments_are_the_einsum_and_matmul_ones_to_round_off(seed, with_numpy):
    data, idx, w = random_rows(seed)
    x = data.take(idx, axis=0)
    centre = np.einsum("qk,qkc->qc", w, x)
    d = x - centre[:, None, :]
    scatter = np.matmul((w[:, :, None] * d).transpose(0, 2, 1), d)
    got_centre, got_scatter = with_numpy(weighted_moments, data, idx, w)
    # The centroid is summed as einsum sums it; BLAS may fuse or reorder the products.
    np.testing.assert_allclose(got_centre, centre, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got_scatter, scatter, rtol=0, atol=1e-13 * np.abs(scatter).max())
    assert np.array_equal(got_scatter, got_scatter.transpose(0, 2, 1))


@pytest.mark.parametrize("k", [PLANE_POINTS, 3, 24])
def test_compiled_moments_are_numpys_to_the_last_bit(k, compiled, with_numpy):
    compiled("mls_kernel")
    data, idx, w = random_rows(k, k=k)
    got = weighted_moments(data, idx, w)
    expected = with_numpy(weighted_moments, data, idx, w)
    for one, other in zip(got, expected):
        assert np.array_equal(one, other)


def test_compiled_least_axes_are_numpys_to_the_last_bit(compiled, with_numpy):
    # Scatters of random rows, of points on planes, on lines (a double
    # smallest eigenvalue) and at one point (zeros), a multiple of the
    # identity, a double largest eigenvalue and a NaN: the same normals and
    # eigenvalues, bit for bit, as the numpy passes give.
    compiled("mls_kernel")
    data, idx, w = random_rows(7)
    scatters = [with_numpy(weighted_moments, data, idx, w)[1]]
    rng = np.random.default_rng(7)
    for dims in (2, 1, 0):
        points = np.zeros((2000, 12, 3))
        points[:, :, :dims] = rng.random((2000, 12, dims)) * 10
        rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        points = points @ rotation + 1000.0
        d = points - points.mean(axis=1, keepdims=True)
        scatters.append(np.einsum("qki,qkj->qij", d, d) / 12)
    scatters.append(np.array([np.zeros((3, 3)), 2 * np.eye(3), np.diag([1.0, 1.0, 4.0]), np.full((3, 3), np.nan)]))
    cov = np.concatenate(scatters)
    normal, values = least_axis(cov)
    expected_normal, expected_values = with_numpy(least_axis, cov)
    assert np.array_equal(normal, expected_normal, equal_nan=True)
    assert np.array_equal(values, expected_values, equal_nan=True)
    assert normal[-3].tolist() == [0.0, 0.0, 1.0]  # every cross product zero


def search_with(switch, monkeypatch, compiled, data):
    """The search over ``data`` of a run with the kernels off ("0": a KD-tree,
    numpy's least axes) or on ("1": the column index, the compiled ones)."""
    monkeypatch.setenv("URBANVOX_JIT", switch)
    if switch == "1":
        compiled("mls_kernel")
        return point_index(data, 1.5)
    return search_tree(data)


@pytest.mark.parametrize("switch", ["0", "1"])
def test_planes_of_points_on_a_tilted_roof_are_that_roof(switch, monkeypatch, compiled):
    # A roof z = 0.4 x - 0.2 y + 30 sampled at 10 points/m², at random in plan:
    # every plane inside it is that plane, through the points' weighted centre.
    rng = np.random.default_rng(2)
    xy = rng.random((4_000, 2)) * 20.0
    data = np.column_stack([xy, 0.4 * xy[:, 0] - 0.2 * xy[:, 1] + 30.0])
    inside = np.flatnonzero(np.all((xy > 3.0) & (xy < 17.0), axis=1))
    centre, normal, flat = mls_planes(data, search_with(switch, monkeypatch, compiled, data), data[inside], 0.5)
    expected = np.array([-0.4, 0.2, 1.0]) / np.linalg.norm([-0.4, 0.2, 1.0])
    assert flat.all()
    assert np.abs(np.abs(normal @ expected) - 1).max() < 1e-12
    on_roof = 0.4 * centre[:, 0] - 0.2 * centre[:, 1] + 30.0
    assert np.abs(centre[:, 2] - on_roof).max() < 1e-11
    assert np.abs(centre[:, :2] - xy[inside]).max() < 0.6  # within the 12 nearest points' reach


def test_points_on_a_line_make_no_flat_plane():
    data = np.column_stack([np.linspace(0, 10, 50), np.linspace(0, 5, 50), np.full(50, 3.0)])
    _, normal, flat = mls_planes(data, search_tree(data), data[20:30], 0.5)
    assert not flat.any()
    assert np.allclose(np.linalg.norm(normal, axis=1), 1.0)
    _, values = least_axis(np.zeros((1, 3, 3)))
    assert values.tolist() == [[0.0, 0.0, 0.0]]


@pytest.mark.parametrize("radius", [4.0, 5.0, 6.5])  # 16, 20 and 26 sigmas
@pytest.mark.parametrize("switch", ["0", "1"])
def test_a_point_far_from_all_others_makes_the_plane_of_its_neighbours(switch, monkeypatch, compiled, radius):
    # Its neighbours weigh 1e-111 to 1e-294 beside it, and so does the
    # scatter: the least axis's cubes or squares underflowed, which gave no
    # plane (NaN) at 16 sigmas and a flat one with the normal (0, 0, 1) at 20
    # and 26 sigmas, whatever the neighbours' layout. Now: eleven neighbours
    # on a circle of a tilted plane make that plane, on a line no plane, and
    # anywhere around the plane LAPACK finds (which scales such matrices
    # too). No warning (the 2 km city at 0.5 m warned from its workers).
    import warnings

    normal = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    u = np.cross(normal, [1.0, 0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    angle = 2 * np.pi * np.arange(11) / 11
    circle = radius * (np.cos(angle)[:, None] * u + np.sin(angle)[:, None] * v)
    rng = np.random.default_rng(5)
    line = radius * rng.uniform(1.0, 1.2, (11, 1)) * u
    around = rng.normal(size=(11, 3))
    around *= radius * rng.uniform(1.0, 1.1, (11, 1)) / np.linalg.norm(around, axis=1, keepdims=True)
    point = np.array([100.0, 200.0, 30.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for ring in (circle, line, around):
            data = np.concatenate([[point], point + ring])
            centre, found, flat = mls_planes(data, search_with(switch, monkeypatch, compiled, data), data[:1], 0.25)
            assert np.isfinite(found).all() and np.abs(centre[0] - point).max() < 1e-9
            weight = np.exp(-(np.linalg.norm(ring, axis=1) / 0.25) ** 2)
            values, axes = np.linalg.eigh(np.einsum("k,ki,kj->ij", weight, ring, ring))
            assert flat[0] == (values[1] > 1e-3 * values[2])
            assert flat[0] or ring is not circle
            assert not flat[0] or ring is not line
            if flat[0]:
                assert abs(abs(found[0] @ axes[:, 0]) - 1) < 1e-9
            if ring is circle:
                assert abs(abs(found[0] @ normal) - 1) < 1e-9
        _, values = least_axis(np.diag([3e-110, 2e-110, 1e-110])[None])
    assert np.isnan(values).all()  # least_axis alone: mls_planes scales such scatters first
