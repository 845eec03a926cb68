"""Vertex-only Catmull-Clark step (core.smooth) against a per-node reference."""
import numpy as np
import pytest

from core.grid import VoxelGrid
from core.smooth import CatmullClarkStep
from core.surface import AIR_REGION, GROUND_REGION, SurfaceModel


def catmull_clark_reference(nodes, quads, i):
    """(F + 2 R + (n - 3) P) / n at node i, from its faces and edges, one by one."""
    faces = [q for q in quads if i in q]
    neighbours = set()
    for q in faces:
        k = list(q).index(i)
        neighbours.update({q[(k + 1) % 4], q[(k - 1) % 4]})
    n = len(neighbours)
    f = np.mean([nodes[q].mean(axis=0) for q in faces], axis=0)
    r = np.mean([(nodes[i] + nodes[j]) / 2 for j in neighbours], axis=0)
    return (f + 2 * r + (n - 3) * nodes[i]) / n


@pytest.mark.parametrize("seed", range(3))
def test_the_step_is_catmull_clark_at_every_node_of_closed_and_open_surfaces(seed):
    rng = np.random.default_rng(seed)
    # Two random blocks of voxels on a ground layer, under air: the block
    # surfaces are closed, the ground's is open at the domain box.
    regions = np.full((6, 5, 5), AIR_REGION, dtype=np.int32)
    regions[:, :, 0] = GROUND_REGION
    regions[1:3, 1:4, 1:1 + rng.integers(1, 4)] = 1
    regions[4, rng.integers(0, 4):, 1:3] = 2
    model = SurfaceModel.from_regions(VoxelGrid(np.zeros(3), np.zeros(3), 1.0, regions.shape), regions)
    nodes = model.nodes + rng.normal(scale=0.1, size=model.nodes.shape)  # not a lattice any more
    a, b = model.regions[:, 0], model.regions[:, 1]
    for faces in (model.quads[(a > 0) | (b > 0)], model.quads[(a == GROUND_REGION) | (b == GROUND_REGION)]):
        step = CatmullClarkStep(faces, len(nodes))
        assert np.array_equal(step.nodes, np.unique(faces))
        moved = step(nodes)
        expected = np.array([catmull_clark_reference(nodes, faces, i) for i in step.nodes])
        np.testing.assert_allclose(moved, expected, rtol=0, atol=1e-12)


def test_sorted_unique_is_np_unique_on_ordered_and_shuffled_keys():
    # The Catmull-Clark step's edge keys go through sorted_unique (numpy's
    # stable sort, fast on keys nearly in order): the same keys as np.unique.
    from core.topology import sorted_unique

    rng = np.random.default_rng(4)
    for n in (0, 1, 7, 10_000):
        keys = np.sort(rng.integers(0, n // 2 + 1, n)) + rng.integers(0, 3, n)  # nearly in order
        for values in (keys, rng.permutation(keys)):
            assert np.array_equal(sorted_unique(values), np.unique(values))


def test_dense_unique_and_rank_in_are_the_sorting_ones():
    # Region ids and region pairs (a small range) are counted, not sorted:
    # the same values, inverse and ranks as np.unique and a binary search,
    # on both sides of the range limit and in several integer types.
    from core.surface import rank_in
    from core.topology import dense_unique

    rng = np.random.default_rng(5)
    cases = [rng.integers(-2, 300, 5_000), rng.integers(-2, 300, (2_000, 2)).astype(np.int32),
             rng.integers(-10**9, 10**9, 50), rng.integers(0, 3, 10).astype(np.int16), np.zeros(0, np.int64),
             rng.integers(-100, 101, 300).astype(np.int8)]  # its range overflows int8
    for values in cases:
        unique, inverse = np.unique(values, return_inverse=True)
        inverse = inverse.ravel()  # numpy 2 gives it the shape of values; dense_unique's is flat, as numpy 1's
        got, got_inverse = dense_unique(values, return_inverse=True)
        assert got.dtype == unique.dtype and np.array_equal(got, unique)
        assert np.array_equal(got_inverse, inverse) and np.array_equal(dense_unique(values), unique)
        wanted = rng.permutation(unique)[: len(unique) // 2 + 1]
        position = {v: i for i, v in enumerate(wanted.tolist())}
        expected = np.array([position.get(v, -1) for v in values.ravel().tolist()]).reshape(values.shape)
        assert np.array_equal(rank_in(values, wanted), expected)


def test_each_surface_is_stepped_on_the_faces_around_its_moving_nodes_only():
    # smooth() leaves out the faces that touch no node following that
    # surface and moving (the ground under the blocks, the domain's bottom
    # and sides): the positions are those of a step over all its faces, to
    # the last bit, pass after pass.
    from core.quality import accept_moves
    from core.smooth import NodeRoles, smooth

    rng = np.random.default_rng(4)
    regions = np.full((10, 9, 7), AIR_REGION, dtype=np.int32)
    regions[:, :, :2] = GROUND_REGION
    regions[2:5, 2:6, 2:5] = 1
    regions[6:9, 1:4, 2:4] = 2
    grid = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, regions.shape)
    model = SurfaceModel.from_regions(grid, regions)
    model.nodes[:] = model.nodes + rng.normal(scale=0.05, size=model.nodes.shape)
    roles = NodeRoles.of(model, np.zeros(3), np.asarray(regions.shape, float))
    got, _ = smooth(model, roles, passes=3)
    a, b = model.regions[:, 0], model.regions[:, 1]
    blocks = CatmullClarkStep(model.quads[(a > 0) | (b > 0)], len(model.nodes))
    ground = CatmullClarkStep(model.quads[(a == GROUND_REGION) | (b == GROUND_REGION)], len(model.nodes))
    keep = roles.fixed_axes | ~roles.movable[:, None]
    nodes = model.nodes.copy()
    for _ in range(3):
        target = nodes.copy()
        target[blocks.nodes[roles.on_block[blocks.nodes]]] = blocks(nodes)[roles.on_block[blocks.nodes]]
        target[ground.nodes[~roles.on_block[ground.nodes]]] = ground(nodes)[~roles.on_block[ground.nodes]]
        nodes, _ = accept_moves(nodes, np.where(keep, nodes, target), model.quads, 0.2)
    assert roles.movable.sum() > 100 and not np.array_equal(got, model.nodes)
    assert np.array_equal(got, nodes)
