"""The compiled nodal normals (core.normals_kernel) against numpy's
(core.project): the same vectors to the last bit, signs of zeros too."""
import numpy as np
import pytest


@pytest.fixture
def kernel(compiled):
    return compiled("normals_kernel")


@pytest.mark.parametrize("dtype", [np.int64, np.int32])
def test_node_normals_are_numpys_to_the_last_bit(monkeypatch, kernel, dtype):
    from core.project import node_normals

    rng = np.random.default_rng(5)
    nodes = rng.normal(scale=0.2, size=(30_000, 3)) + rng.integers(0, 40, size=(30_000, 3))
    nodes[50:100] = nodes[:50]
    quads = rng.integers(0, 25_000, size=(80_000, 4)).astype(dtype)  # the last nodes on no quad
    # Equal diagonals (i -> j and i + 50 -> j + 50): quads with a zero normal.
    i, j = rng.integers(0, 50, size=(2, 30))
    quads[:30] = np.column_stack([i, i + 50, j, j + 50])
    with monkeypatch.context() as patch:
        patch.setenv("URBANVOX_JIT", "0")
        expected = node_normals(nodes, quads, len(nodes))
    got = kernel.node_normals(nodes, quads, len(nodes))
    assert got.shape == expected.shape and got.tobytes() == expected.tobytes()  # signs of zeros too
    assert not got[25_000:].any() and np.allclose(np.linalg.norm(got[100:25_000], axis=1), 1.0)


@pytest.mark.parametrize("threads", ["1", "3"])
@pytest.mark.parametrize("dtype", [np.int64, np.int32])
def test_outward_normals_are_numpys_to_the_last_bit(monkeypatch, kernel, dtype, threads):
    """Blocks on the ground, one on another's roof, one touching another by
    an edge, a pit in the ground, in a box: each selected node's normal out of
    its block, else out of the ground, as numpy's sums on the gathered faces;
    on one thread, and on three in blocks of 64 rows (the faces listed by
    blocks and joined, the totals made by blocks)."""
    from core import parallel
    from core.grid import VoxelGrid
    from core.project import outward_normals
    from core.smooth import NodeRoles
    from core.surface import AIR_REGION, GROUND_REGION, SurfaceModel

    rng = np.random.default_rng(11)
    regions = np.full((14, 12, 9), AIR_REGION, dtype=np.int32)
    regions[:, :, :2] = GROUND_REGION
    regions[1:5, 1:6, 2:6] = 1
    regions[2:4, 2:4, 6:8] = 2   # on block 1's roof
    regions[7:12, 3:10, 2:4] = 3
    regions[5:7, 6:8, 2:5] = 4   # touches block 1 by an edge
    regions[9, 5, 1] = AIR_REGION  # a pit in the ground
    model = SurfaceModel.from_regions(VoxelGrid(np.zeros(3), np.zeros(3), 1.0, regions.shape), regions)
    model = SurfaceModel(nodes=model.nodes, quads=model.quads.astype(dtype), regions=model.regions)
    roles = NodeRoles.of(model, np.zeros(3), np.asarray(regions.shape, float))
    monkeypatch.setenv("URBANVOX_THREADS", threads)
    monkeypatch.setattr(parallel, "BALANCED_ROWS", 64)
    assert len(parallel.balanced_blocks(len(model.quads))) >= 4
    nodes = model.nodes + rng.normal(scale=0.15, size=model.nodes.shape)
    nodes[::7] = model.nodes[::7]  # flat patches: zero components, whose signs must match too
    for select in (rng.random(len(nodes)) < 0.6, np.ones(len(nodes), bool), roles.on_block, ~roles.on_block):
        with monkeypatch.context() as patch:
            patch.setenv("URBANVOX_JIT", "0")
            expected = outward_normals(model, nodes, roles, select)
        got = kernel.outward_node_normals(nodes, model.quads, model.regions, roles.on_block, select, GROUND_REGION)
        assert got.shape == (np.count_nonzero(select), 3) and got.tobytes() == expected.tobytes()
        assert np.allclose(np.linalg.norm(got[roles.on_ground[select]], axis=1), 1.0)


def test_outward_normals_of_no_quads_are_zero(kernel):
    every = np.ones(4, bool)
    normal = kernel.outward_node_normals(np.ones((4, 3)), np.zeros((0, 4), np.int64), np.zeros((0, 2), np.int32),
                                         every, every, -1)
    assert normal.shape == (4, 3) and not normal.any()
    assert kernel.outward_node_normals(np.ones((4, 3)), np.zeros((0, 4), np.int64), np.zeros((0, 2), np.int32),
                                       every, ~every, -1).shape == (0, 3)
