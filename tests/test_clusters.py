"""core.clusters.split_clusters on point groups with known answers."""
import numpy as np
import pytest

from core.clusters import split_clusters


@pytest.mark.parametrize("groups", [1, 3])
def test_clusters_of_points_are_those_of_their_squares(groups):
    """Groups of points farther apart than the gap, and one group, over two
    arrays (one of them empty in the one-group case), negative coordinates too."""
    rng = np.random.default_rng(groups)
    centres = np.array([[-400.0, 120.0, 0.0], [300.0, -80.0, 5.0], [900.0, 900.0, 2.0]])[:groups]
    points = np.concatenate([c + rng.uniform(-60, 60, (5000, 3)) for c in centres])
    building = points[::7] + [0, 0, 10]
    parts = [points, building if groups > 1 else np.zeros((0, 3))]
    got = split_clusters(parts, 50.0)
    assert [len(g) for g in got] == [len(p) for p in parts]
    if groups == 1:
        assert not got[0].any()
        return
    # Each group one cluster, numbered by the first square met along x.
    expected = np.repeat(np.arange(groups), 5000)
    assert np.array_equal(got[0], expected) and np.array_equal(got[1], expected[::7])
