"""The compiled search of the critical cubes (core.manifold_kernel) against
numpy's (core.manifold): the same cubes, in the same order."""
import numpy as np
import pytest

from core import manifold
from core.classify import AIR, BUILDING, GROUND


@pytest.fixture
def kernel(compiled):
    return compiled("manifold_kernel")


@pytest.mark.parametrize("seed", range(12))
def test_critical_cubes_are_numpys(with_numpy, kernel, seed):
    """Random grids from a single cube to tens of thousands, flat along any
    axis (no cube at all), labels from noise to a few smooth regions."""
    rng = np.random.default_rng(seed)
    shape = tuple(int(v) for v in rng.integers(1, 40, 3))
    labels = rng.choice(np.array([GROUND, BUILDING, AIR], np.uint8), shape, p=[0.2, 0.3, 0.5])
    if seed % 2:
        labels = np.repeat(labels[::4], 4, axis=0)[:shape[0]]  # runs of equal labels
    expected = with_numpy(manifold._all_critical_cubes, labels)
    got = kernel.critical_cubes(labels, manifold._CRITICAL_BY_LABEL_SUM)
    assert got.dtype == np.int64 and np.array_equal(got, expected)
    assert min(shape) < 2 or len(expected) > 0


@pytest.mark.parametrize("seed", range(12))
def test_critical_cubes_around_voxels_are_numpys_and_the_whole_grids_ones_there(with_numpy, kernel, seed):
    """The critical cubes holding one of some voxels (at the grid's faces
    and corners too, repeated, or none): numpy's, and those of the whole
    grid's that hold one of them."""
    rng = np.random.default_rng(100 + seed)
    shape = tuple(int(v) for v in rng.integers(1, 30, 3))
    labels = rng.choice(np.array([GROUND, BUILDING, AIR], np.uint8), shape, p=[0.2, 0.3, 0.5])
    cells = rng.integers(0, labels.size, int(rng.integers(0, 60)))
    cells = np.concatenate([cells, cells[:5], [0, labels.size - 1]]).astype(np.int64)
    expected = with_numpy(manifold._critical_cubes_around, labels, cells)
    got = manifold._critical_cubes_around(labels, cells)
    assert got.dtype == np.int64 and np.array_equal(got, expected)
    whole = manifold._all_critical_cubes(labels)
    ijk = np.column_stack(np.unravel_index(whole, shape))
    cell_ijk = np.column_stack(np.unravel_index(cells, shape))
    holds = ((cell_ijk[None, :, :] - ijk[:, None, :] >= 0) & (cell_ijk[None, :, :] - ijk[:, None, :] <= 1)).all(axis=2)
    assert np.array_equal(got, whole[holds.any(axis=1)])


def test_repair_gives_the_same_labels(with_numpy, kernel):
    """The whole well-composed repair, with the kernel and without it."""
    rng = np.random.default_rng(3)
    labels = np.full((40, 30, 20), AIR, np.uint8)
    labels[:, :, :3] = GROUND
    for _ in range(60):
        x, y, z = rng.integers(0, 36), rng.integers(0, 26), rng.integers(3, 16)
        labels[x:x + rng.integers(1, 5), y:y + rng.integers(1, 5), z:z + rng.integers(1, 5)] = BUILDING
    expected = labels.copy()
    added = with_numpy(manifold.make_well_composed, expected)
    assert added > 0 and manifold.make_well_composed(labels) == added
    assert np.array_equal(labels, expected) and len(kernel.critical_cubes(labels, manifold._CRITICAL_BY_LABEL_SUM)) == 0
