"""The compiled entity search of the gmsh export (core.export_kernel) against
its numpy twin (core.export._msh_entities): the same patches, shells, order
and boxes, numbered alike."""
import numpy as np
import pytest

from core import export


@pytest.fixture
def kernel(compiled):
    return compiled("export_kernel")


def _random_faces(seed):
    """Faces on a few hundred nodes in a few interfaces (many small patches,
    nodes shared across interfaces), regions partly not written (-1), and
    coordinates with zeros of both signs."""
    rng = np.random.default_rng(seed)
    n_nodes, n_faces, n_interfaces = int(rng.integers(5, 400)), int(rng.integers(1, 3000)), int(rng.integers(1, 9))
    faces = rng.integers(0, n_nodes, (n_faces, int(rng.choice([3, 4]))))
    which = rng.integers(0, n_interfaces, n_faces)
    side_rank = rng.integers(-1, 5, (n_interfaces, 2))
    world = np.where(rng.random((n_nodes, 3)) < 0.5, rng.choice([-1.5, -0.0, 0.0, 2.25, 7.0], (n_nodes, 3)),
                     rng.random((n_nodes, 3)))
    return faces, which, side_rank, world


@pytest.mark.parametrize("threads", ["1", "3"])
@pytest.mark.parametrize("seed", range(12))
def test_entities_are_numpys(kernel, seed, threads, monkeypatch):
    """Joined on one thread, or in runs of whole groups on three."""
    monkeypatch.setenv("URBANVOX_THREADS", threads)
    args = _random_faces(seed)
    expected = export._msh_entities(*args)
    got = kernel.msh_entities(*args)
    assert len(got) == len(expected) == 7
    assert len(expected[0]) > 1 or seed  # patches to number (the first seed has several)
    for name, a, b in zip(("first_face", "order", "bounds", "items", "shell", "lower", "upper"), got, expected):
        assert a.dtype == b.dtype and np.array_equal(a, b), name
        if a.dtype.kind == "f":
            assert not np.signbit(a[a == 0]).any(), name  # zeros made positive in both


def test_entities_of_separate_squares(kernel):
    """Two squares of interface 0 sharing an edge, one of interface 1 beside
    them: two patches, and the sides of region 0 (rank 0) one shell, of
    region 1 another; boxes of their nodes."""
    faces = np.array([[0, 1, 4, 3], [1, 2, 5, 4], [2, 6, 7, 5]])
    world = np.arange(24.0).reshape(8, 3)
    for found in (kernel.msh_entities(faces, np.array([0, 0, 1]), np.array([[0, 1], [0, 1]]), world),
                  export._msh_entities(faces, np.array([0, 0, 1]), np.array([[0, 1], [0, 1]]), world)):
        first_face, order, bounds, items, shell, lower, upper = found
        assert first_face.tolist() == [0, 2] and order.tolist() == [0, 1, 2] and bounds.tolist() == [0, 2, 3]
        assert items.tolist() == [0, 1, 2, 3] and shell.tolist() == [0, 0, 1, 1]
        assert lower.tolist() == [[0, 1, 2], [6, 7, 8]] and upper.tolist() == [[15, 16, 17], [21, 22, 23]]


def test_runs_of_whole_groups(kernel):
    """Items in groups of 5, 1, 1 and 3 faces: runs end where groups end,
    about equal in faces."""
    from core.export_kernel import _group_runs

    item_set = np.arange(10)
    start = np.arange(11)
    group = np.array([0, 0, 0, 0, 0, 1, 2, 3, 3, 3])
    assert _group_runs(start, item_set, group, 1) == [slice(0, 10)]
    assert _group_runs(start, item_set, group, 2) == [slice(0, 5), slice(5, 10)]
    assert _group_runs(start, item_set, group, 3) == [slice(0, 5), slice(5, 6), slice(6, 10)]
    assert _group_runs(start, item_set, np.zeros(10, dtype=np.int64), 4) == [slice(0, 10)]
