"""The compiled passes over the blocks (core.blocks_kernel) against numpy's
(core.blocks): the same attributes, the same blocks dropped and renumbered."""
import numpy as np
import pytest
from scipy import ndimage

from core import blocks as blocks_module
from core.classify import AIR, BUILDING, FACE_ADJACENCY, GROUND
from core.grid import VoxelGrid


@pytest.fixture
def kernel(compiled):
    return compiled("blocks_kernel")


def random_city(seed, shape=(60, 50, 30)):
    """Ground below a random relief, buildings of random boxes and single
    voxels above it (towers, sheds, blocks that overhang and touch)."""
    rng = np.random.default_rng(seed)
    labels = np.full(shape, AIR, np.uint8)
    relief = ndimage.uniform_filter(rng.integers(1, 6, shape[:2]).astype(float), 7).astype(int)
    labels[np.arange(shape[2])[None, None, :] < relief[..., None]] = GROUND
    for _ in range(80):
        x, y = rng.integers(0, shape[0] - 3), rng.integers(0, shape[1] - 3)
        z = int(relief[x, y]) + rng.integers(0, 4)
        dx, dy, dz = rng.integers(1, 9, 3)
        labels[x:x + dx, y:y + dy, z:z + dz] = BUILDING
    loose = rng.integers(0, shape, (200, 3))
    labels[tuple(loose.T)] = BUILDING
    return labels, VoxelGrid(np.zeros(3), np.array([10.0, 20.0, -3.0]), 0.5, shape)


@pytest.mark.parametrize("seed", range(40))
def test_runs_number_the_volumes_as_scipy(kernel, seed):
    """Random grids from one voxel to a few thousand, sparse to dense (long
    runs, overhangs, columns of several runs), flat along any axis."""
    rng = np.random.default_rng(seed)
    shape = tuple(int(v) for v in rng.integers(1, 16, 3))
    fill = rng.uniform(0.1, 0.8)
    labels = np.where(rng.random(shape) < fill, BUILDING, np.where(rng.random(shape) < 0.5, GROUND, AIR))
    labels = labels.astype(np.uint8)
    expected, n = ndimage.label(labels == BUILDING, structure=FACE_ADJACENCY)
    got, m = kernel.label_runs(labels, BUILDING)
    assert got.dtype == np.int32 and m == n and np.array_equal(got, expected)


def test_runs_number_a_city_as_scipy(kernel):
    labels, _ = random_city(3)
    expected, n = ndimage.label(labels == BUILDING, structure=FACE_ADJACENCY)
    got, m = kernel.label_runs(labels, BUILDING)
    assert n > 50 and m == n and np.array_equal(got, expected)
    # No building voxel at all, and a grid of one.
    assert kernel.label_runs(np.full((3, 4, 5), AIR, np.uint8), BUILDING)[1] == 0
    one, k = kernel.label_runs(np.full((1, 1, 1), BUILDING, np.uint8), BUILDING)
    assert k == 1 and one.tolist() == [[[1]]]


def test_block_extents_are_numpys(monkeypatch, kernel):
    labels, grid = random_city(0)
    blocks, n = blocks_module.label_blocks(labels)
    assert n > 50
    with monkeypatch.context() as patch:
        patch.setenv("URBANVOX_JIT", "0")
        expected = blocks_module.block_attributes(blocks, n, grid)
    got = blocks_module.block_attributes(blocks, n, grid)
    for name in ("block_id", "n_voxels", "volume", "footprint_area", "ground_z", "top_z"):
        assert np.array_equal(getattr(got, name), getattr(expected, name)), name
    # An id that does not occur: lowest layer nz, highest -1, as find_objects' None.
    count, columns, lowest, highest = kernel.block_extents(blocks, n + 1)
    assert (count[-1], columns[-1], lowest[-1], highest[-1]) == (0, 0, labels.shape[2], -1)


@pytest.mark.parametrize("seed", [1, 2])
def test_blocks_above_thresholds_drop_and_renumber_as_numpy(monkeypatch, kernel, seed):
    labels, grid = random_city(seed)
    thresholds = (2.0, 3.0, 2.0)  # m, m², m³ (voxels of 0.5 m)
    expected_labels = labels.copy()
    with monkeypatch.context() as patch:
        patch.setenv("URBANVOX_JIT", "0")
        expected = blocks_module.blocks_above_thresholds(expected_labels, grid, *thresholds)
    calls = []
    monkeypatch.setattr(kernel, "drop_and_renumber",
                        lambda *args, real=kernel.drop_and_renumber: calls.append(1) or real(*args))
    got = blocks_module.blocks_above_thresholds(labels, grid, *thresholds)
    assert calls and 0 < expected[2] == got[2] and len(expected[1]) > 10
    assert np.array_equal(got[0], expected[0]) and np.array_equal(labels, expected_labels)
    assert got[1].block_id.tolist() == list(range(1, len(got[1]) + 1))
    for name in ("n_voxels", "volume", "footprint_area", "ground_z", "top_z"):
        assert np.array_equal(getattr(got[1], name), getattr(expected[1], name)), name
    # What is left is what a fresh labelling finds.
    fresh, m = blocks_module.label_blocks(labels)
    assert m == len(got[1]) and np.array_equal(fresh, got[0])


@pytest.mark.parametrize("seed", range(4))
def test_block_columns_are_numpys(with_numpy, kernel, seed):
    """The columns each block covers, sorted by block then column: blocks that
    overhang each other share columns, and a column may hold a block twice."""
    labels, _ = random_city(seed)
    blocks, n = ndimage.label(labels == BUILDING, structure=FACE_ADJACENCY)
    blocks = blocks.astype(np.int32)
    expected = with_numpy(blocks_module.block_columns, blocks)
    got = kernel.block_columns(blocks, n)
    assert got.dtype == np.int64 and np.array_equal(got, expected)
    assert len(expected) > n  # blocks cover several columns
    assert kernel.block_columns(np.zeros((3, 2, 4), np.int32), 0).shape == (0, 3)


@pytest.mark.parametrize("largest", [False, True])
def test_extremes_per_block_are_numpys_ufunc_at(kernel, largest):
    """Per-block minimum and maximum as np.minimum.at and np.maximum.at give
    them, blocks with no value and NaN values included."""
    rng = np.random.default_rng(7)
    for dtype in (np.int32, np.int64):
        owner = rng.integers(0, 50, 20_000).astype(dtype)
        values = rng.random(20_000)
        values[rng.integers(0, 20_000, 5)] = np.nan
        values[owner == 3] = 0.25  # ties
        owner[owner == 7] = 8  # a block with no value
        initial = -np.inf if largest else np.inf
        expected = np.full(51, initial)
        (np.maximum if largest else np.minimum).at(expected, owner, values)
        got = kernel.extremes_into(np.full(51, initial), owner, values, largest)
        np.testing.assert_array_equal(got, expected)
        assert np.isnan(expected).sum() >= 3 and expected[7] == initial
