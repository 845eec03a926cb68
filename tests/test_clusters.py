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


def test_data_spread_far_are_clustered_through_their_occupied_cells_alike(monkeypatch):
    """Past a whole grid's size (a stray point thousands of km away), the
    clusters come from the occupied cells only: the same clusters, numbered
    alike, and a stray point is a cluster of its own (without the 400,000 x
    400,000 grid of flags that one point 20,000 km away asked for)."""
    import core.clusters

    rng = np.random.default_rng(4)
    centres = np.array([[-400.0, 120.0, 0.0], [300.0, -80.0, 5.0], [900.0, 900.0, 2.0], [-400, 2000, 0],
                        [2000, -400, 0]])
    # Odd shapes too: an L whose arms meet diagonally, and rings of squares.
    points = np.concatenate([c + rng.uniform(-160, 160, (4000, 3)) for c in centres]
                            + [rng.uniform(-2000, 3000, (300, 3))])
    parts = [points[::2], points[1::2]]
    dense = split_clusters(parts, 50.0)
    monkeypatch.setattr(core.clusters, "DENSE_CELLS", 0)
    sparse = split_clusters(parts, 50.0)
    assert max(g.max() for g in dense) >= 5
    assert all(np.array_equal(d, s) for d, s in zip(dense, sparse))
    monkeypatch.undo()
    stray = np.concatenate([points, [[2e7, 1e6, 0.0]]])
    got = split_clusters([stray, np.zeros((0, 3))], 50.0)[0]
    assert got[-1] == got.max() and np.count_nonzero(got == got[-1]) == 1
    assert np.array_equal(got[:-1], split_clusters([points, np.zeros((0, 3))], 50.0)[0])


def test_data_wider_than_any_city_are_refused_with_the_reason():
    from core.errors import UrbanvoxError

    with pytest.raises(UrbanvoxError, match="a corrupt coordinate or scale"):
        split_clusters([np.array([[0.0, 0, 0], [1e300, 0, 0]])], 50.0)
