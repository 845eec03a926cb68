"""Per-block measures (core.measure) on voxel blocks with known answers."""
import numpy as np
import pytest

from core.grid import VoxelGrid
from core.measure import measure_blocks
from core.surface import AIR_REGION, GROUND_REGION, SurfaceModel


@pytest.mark.parametrize("touching", [False, True])
def test_volumes_areas_and_node_distances_per_block(touching):
    # A 2 x 2 x 2 block and a 1 x 1 x 1 block on the ground; touching, they
    # share a vertical edge (and its nodes), which the distances must count
    # once per block.
    regions = np.full((6, 6, 5), AIR_REGION, dtype=np.int32)
    regions[:, :, 0] = GROUND_REGION
    regions[1:3, 1:3, 1:3] = 1
    at = 3 if touching else 4
    regions[at, at, 1] = 2
    model = SurfaceModel.from_regions(VoxelGrid(np.zeros(3), np.zeros(3), 1.0, regions.shape), regions)
    distance = np.random.default_rng(2).random(len(model.nodes))
    m = measure_blocks(model, model.nodes, 2, distance)
    np.testing.assert_allclose(m.volume, [8.0, 1.0])
    np.testing.assert_allclose(m.roof_area, [4.0, 1.0])
    np.testing.assert_allclose(m.facade_area, [16.0, 4.0])
    np.testing.assert_allclose(m.area, [24.0, 6.0])
    for block in (1, 2):
        nodes = np.unique(model.closed_surface(block))
        assert m.mean_dist[block - 1] == pytest.approx(distance[nodes].mean(), rel=1e-14)
        assert m.max_dist[block - 1] == distance[nodes].max()
    shared = np.intersect1d(model.closed_surface(1), model.closed_surface(2))
    assert len(shared) == (2 if touching else 0)


@pytest.mark.parametrize("threads", ["1", "3"])
def test_compiled_sums_are_numpys_to_the_last_bit(compiled, with_numpy, monkeypatch, threads):
    """The per-block sums of core.measure_kernel against measure_blocks's numpy
    code, on random blocks (faces oriented out of and into their block, both
    diagonals) with shaken nodes: the same volumes, areas and qualities, bit for
    bit, whether one thread sums every block or three share them out."""
    monkeypatch.setenv("URBANVOX_THREADS", threads)
    from core.blocks import label_blocks
    from core.classify import AIR
    from test_blocks_kernel import random_city

    compiled("measure_kernel")
    labels, grid = random_city(3, shape=(40, 30, 20))
    blocks, n = label_blocks(labels)
    regions = np.where(blocks > 0, blocks, np.where(labels == AIR, AIR_REGION, GROUND_REGION)).astype(np.int32)
    model = SurfaceModel.from_regions(grid, regions)
    nodes = model.nodes + np.random.default_rng(5).normal(scale=0.2, size=model.nodes.shape)
    a, b = model.regions[:, 0], model.regions[:, 1]
    assert ((a > 0) & (b <= 0)).any() and ((b > 0) & (a <= 0)).any()  # faces both ways round
    got = measure_blocks(model, nodes, n)
    expected = with_numpy(measure_blocks, model, nodes, n)
    for name in ("volume", "area", "roof_area", "facade_area", "min_quality", "mean_quality"):
        assert np.array_equal(getattr(got, name), getattr(expected, name)), name
    assert n > 20 and (got.volume > 0).all()
