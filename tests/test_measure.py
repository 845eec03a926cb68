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
