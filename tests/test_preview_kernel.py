"""The preview's compiled culling and depth buffer (core.preview_kernel)
against its numpy twin (core.preview.nearest_faces): the same face in
every pixel, the same box."""
import numpy as np
import pytest

from core import preview


@pytest.fixture
def kernel(compiled):
    return compiled("preview_kernel")


def _scene(rng, n, flat_share):
    """Triangles of every size over a 60 x 40 view, half turned away, some
    sharing one depth (ties go to the first face), some degenerate."""
    centre = rng.random((n, 1, 3)) * [60, 40, 10]
    corners = centre + rng.normal(0, rng.choice([0.2, 2.0, 8.0], (n, 1, 1)), (n, 3, 3))
    corners[rng.random(n) < flat_share, :, 2] = 5.0
    corners[:3] = centre[:3]  # zero area: never turned to the viewer
    nodes = corners.reshape(-1, 3)
    order = rng.permutation(len(nodes))  # nodes in any order, faces pointing to them
    faces = np.argsort(order).reshape(-1, 3)
    return tuple(np.ascontiguousarray(nodes[order, axis]) for axis in range(3)), tuple(faces.T.copy())


def _same(got, expected):
    assert got[0].dtype == expected[0].dtype and np.array_equal(got[0], expected[0])
    assert np.array_equal(got[1], expected[1]) and np.array_equal(got[2], expected[2])


@pytest.mark.parametrize("seed", range(6))
def test_nearest_faces_are_numpys(kernel, seed):
    rng = np.random.default_rng(seed)
    columns, faces = _scene(rng, int(rng.integers(10, 4000)), flat_share=0.5 if seed % 2 else 0.0)
    expected = preview.nearest_faces(columns, faces)
    _same(kernel.nearest_faces(columns, faces), expected)
    drawn = expected[0][expected[0] >= 0]
    x, y = columns[0], columns[1]
    a, b, c = faces
    towards = (x[b] - x[a]) * (y[c] - y[a]) - (y[b] - y[a]) * (x[c] - x[a])
    assert len(drawn) > 100 and (towards[drawn] > 0).all() and (towards < 0).sum() > len(a) // 3


def test_ties_go_to_the_first_face(kernel):
    """Two copies of a triangle at one depth: every pixel is the first's, both ways."""
    columns = (np.array([0.0, 9, 0]), np.array([0.0, 0, 9]), np.full(3, 2.0))
    faces = (np.array([0, 0]), np.array([1, 1]), np.array([2, 2]))
    for nearest, _, _ in (preview.nearest_faces(columns, faces), kernel.nearest_faces(columns, faces)):
        assert set(nearest.tolist()) == {-1, 0}


def test_nothing_turned_to_the_viewer(kernel):
    columns = (np.array([0.0, 0, 9]), np.array([0.0, 9, 0]), np.zeros(3))  # clockwise: turned away
    faces = (np.array([0]), np.array([1]), np.array([2]))
    for found in (preview.nearest_faces(columns, faces), kernel.nearest_faces(columns, faces)):
        assert found[0].tolist() == [-1] and found[1] is None and found[2] is None
    empty = (np.zeros(0, dtype=np.int64),) * 3
    assert kernel.nearest_faces(columns, empty)[1] is None and preview.nearest_faces(columns, empty)[1] is None
