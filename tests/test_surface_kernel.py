"""The compiled face extraction (core.surface_kernel) against numpy's
(core.surface.faces_between): the same faces, corners and regions, in the same order."""
import numpy as np
import pytest

from core import surface


@pytest.fixture
def kernel(compiled):
    return compiled("surface_kernel")


@pytest.mark.parametrize("seed", range(30))
def test_faces_are_numpys_on_random_volumes(with_numpy, kernel, seed):
    """Volumes from one voxel to a few hundred, flat along any axis, with
    regions that change voxel to voxel or hardly at all."""
    rng = np.random.default_rng(seed)
    shape = tuple(int(v) for v in rng.integers(1, 9, 3))
    regions = rng.integers(-2, 1 + seed % 4, shape).astype(np.int32)
    expected = with_numpy(surface.faces_between, regions)
    got = kernel.faces_between(regions, surface.OUTSIDE_REGION, surface._CORNERS)
    for a, b in zip(got, expected):
        assert a.dtype == b.dtype and np.array_equal(a, b)


def test_surface_models_of_a_city_are_the_same(with_numpy, kernel):
    """Ground, air and forty blocks that touch and overhang: the model numpy
    makes, node for node and quad for quad."""
    from core.grid import VoxelGrid

    rng = np.random.default_rng(1)
    shape = (60, 50, 24)
    regions = np.full(shape, surface.AIR_REGION, np.int32)
    regions[:, :, :5] = surface.GROUND_REGION
    for block in range(1, 41):
        x, y = rng.integers(0, 52), rng.integers(0, 42)
        z = 5 + rng.integers(0, 3)
        regions[x:x + rng.integers(2, 9), y:y + rng.integers(2, 9), z:z + rng.integers(2, 15)] = block
    grid = VoxelGrid(np.zeros(3), np.array([100.0, 200.0, -4.0]), 0.5, shape)
    expected = with_numpy(surface.SurfaceModel.from_regions, grid, regions)
    got = surface.SurfaceModel.from_regions(grid, regions)
    assert len(got.quads) > 5000
    for name in ("nodes", "quads", "regions"):
        assert np.array_equal(getattr(got, name), getattr(expected, name)), name
    # Every block's surface is closed: each edge of its quads is used twice.
    quads = got.closed_surface(7)
    edges = np.sort(np.stack([quads, np.roll(quads, -1, axis=1)], axis=-1).reshape(-1, 2), axis=1)
    assert len(quads) >= 6 and (np.unique(edges, axis=0, return_counts=True)[1] % 2 == 0).all()


@pytest.mark.parametrize("dtype", [np.int64, np.int32])
@pytest.mark.parametrize("size,count", [(1, 5), (64, 100), (65, 3), (10_000, 50_000), (1_000_003, 20_000)])
def test_unique_nodes_are_numpys(with_numpy, kernel, dtype, size, count):
    """Dense and sparse numberings, word edges (64, 65), repeated nodes."""
    rng = np.random.default_rng(size + count)
    flat = rng.integers(0, size, (count // 4 + 1, 4)).astype(dtype)
    flat[0, :2] = [0, size - 1]
    expected = np.unique(flat, return_inverse=True)  # numpy 2: the inverse has flat's shape
    tables = with_numpy(surface.unique_nodes, flat, size)
    used, inverse = kernel.unique_nodes(flat, size)
    assert np.array_equal(used, expected[0]) and np.array_equal(used, tables[0])
    # numpy's tables give flat's shape, its sort (a numbering much larger than flat) a flat intp.
    assert inverse.shape == flat.shape and inverse.dtype == np.int32
    assert np.array_equal(inverse.ravel(), expected[1].ravel()) and np.array_equal(inverse.ravel(), tables[1].ravel())
