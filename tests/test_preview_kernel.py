"""The preview's compiled depth buffer (core.preview_kernel) against its
numpy twin (core.preview.nearest_triangles): the same triangle in every pixel."""
import numpy as np
import pytest

from core import preview


@pytest.fixture
def kernel(compiled):
    return compiled("preview_kernel")


def _triangles(rng, n, flat_share):
    """Triangles of every size on a 60 x 40 picture, some sharing one depth
    (ties broken by the first triangle), some degenerate (one point)."""
    centre = rng.random((n, 1, 3)) * [60, 40, 10]
    corners = centre + rng.normal(0, rng.choice([0.2, 2.0, 8.0], (n, 1, 1)), (n, 3, 3))
    flat = rng.random(n) < flat_share
    corners[flat, :, 2] = 5.0
    corners[:3] = centre[:3]  # zero area: the centroid's one sample
    return [corners[:, k, axis] for k in range(3) for axis in range(3)]


@pytest.mark.parametrize("seed", range(6))
def test_nearest_triangles_are_numpys(kernel, seed):
    rng = np.random.default_rng(seed)
    corners = _triangles(rng, int(rng.integers(3, 4000)), flat_share=0.5 if seed % 2 else 0.0)
    for scale, width, height in ((1.0, 60, 40), (3.7, 222, 148), (0.25, 15, 10)):
        expected = preview.nearest_triangles(corners, 0.0, 0.0, scale, width, height)
        got = kernel.nearest_triangles(corners, 0.0, 0.0, scale, width, height)
        assert got.dtype == expected.dtype and np.array_equal(got, expected)
        assert (expected >= 0).sum() > 10


def test_ties_go_to_the_first_triangle(kernel):
    """Two copies of a triangle at one depth: every pixel is the first's, both ways."""
    one = [np.array([v]) for v in (0.0, 0.0, 2.0, 9.0, 0.0, 2.0, 0.0, 9.0, 2.0)]
    twice = [np.concatenate([value, value]) for value in one]
    for nearest in (preview.nearest_triangles(twice, 0.0, 0.0, 1.0, 10, 10),
                    kernel.nearest_triangles(twice, 0.0, 0.0, 1.0, 10, 10)):
        assert set(nearest.tolist()) == {-1, 0}


def test_nothing_to_draw(kernel):
    empty = [np.zeros(0)] * 9
    for nearest in (preview.nearest_triangles(empty, 0.0, 0.0, 1.0, 3, 2),
                    kernel.nearest_triangles(empty, 0.0, 0.0, 1.0, 3, 2)):
        assert nearest.tolist() == [-1] * 6
