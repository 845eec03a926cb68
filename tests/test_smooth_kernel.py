"""The compiled Catmull-Clark step (core.smooth_kernel) against the sparse
products of core.smooth: the same positions to the last bit."""
import numpy as np
import pytest
from scipy import ndimage

from core.grid import VoxelGrid
from core.smooth import CatmullClarkStep
from core.surface import AIR_REGION, GROUND_REGION, SurfaceModel


@pytest.fixture
def kernel(compiled):
    return compiled("smooth_kernel")


def shaken_blocks(seed):
    """The surface of random blocks on a ground layer, its nodes shaken."""
    rng = np.random.default_rng(seed)
    regions = np.full((30, 25, 12), AIR_REGION, dtype=np.int32)
    regions[:, :, :2] = GROUND_REGION
    building = np.zeros(regions.shape, bool)
    for _ in range(12):
        x, y = rng.integers(1, 24, 2)
        building[x:x + rng.integers(1, 6), y:y + rng.integers(1, 6), 2:2 + rng.integers(1, 9)] = True
    labels, _ = ndimage.label(building)
    regions[building] = labels[building]
    model = SurfaceModel.from_regions(VoxelGrid(np.zeros(3), np.zeros(3), 1.0, regions.shape), regions)
    nodes = model.nodes + rng.normal(scale=0.15, size=model.nodes.shape)
    return model, nodes, rng


@pytest.mark.parametrize("seed", range(3))
def test_the_step_writes_the_sparse_products_positions(monkeypatch, kernel, seed):
    model, nodes, rng = shaken_blocks(seed)
    step = CatmullClarkStep(model.quads, len(nodes))
    which = rng.random(len(step.nodes)) < 0.8
    calls = []
    monkeypatch.setattr(kernel, "step_into", lambda *args, real=kernel.step_into: calls.append(1) or real(*args))
    got = step.into(nodes.copy(), nodes, which)
    with monkeypatch.context() as patch:
        patch.setenv("URBANVOX_JIT", "0")
        expected = step.into(nodes.copy(), nodes, which)
    assert calls and not np.array_equal(expected, nodes)
    assert np.array_equal(got, expected)
    # What the kernel leaves alone: the nodes not asked for, and those of no face.
    untouched = np.ones(len(nodes), bool)
    untouched[step.nodes[which]] = False
    assert np.array_equal(got[untouched], nodes[untouched])


def test_int64_tables_give_the_same_positions(kernel):
    model, nodes, rng = shaken_blocks(5)
    step = CatmullClarkStep(model.quads, len(nodes))
    which = np.ones(len(step.nodes), bool)
    corners, ends, *weights = step.tables()
    narrow = kernel.step_into(nodes.copy(), nodes, step.nodes, which, corners, ends, *weights)
    wide = kernel.step_into(nodes.copy(), nodes, step.nodes, which, corners.astype(np.int64),
                            ends.astype(np.int64), *weights)
    assert corners.dtype == np.int32 and np.array_equal(narrow, wide)
    # The numpy step's matrices, made from the same tables: the index type
    # scipy chose for them when it held the tables, and no copy of them.
    faces, edges = step._incidence()
    for matrix, table in ((faces, corners), (edges, ends)):
        assert matrix.indices.dtype == table.dtype and np.shares_memory(matrix.indices, table)
    expected = nodes.copy()
    expected[step.nodes] = step(nodes)
    assert np.array_equal(narrow, expected)


@pytest.mark.parametrize("seed", range(3))
def test_node_roles_are_numpys(monkeypatch, kernel, seed):
    """The nodes' roles from the kernel's two passes, against NodeRoles.of's
    numpy masks: the domain box's planes, the ground/building/air line."""
    from core.smooth import NodeRoles

    model, _, _ = shaken_blocks(seed)
    box = (np.zeros(3), np.array([30.0, 25.0, 12.0]))
    got = NodeRoles.of(model, *box)
    with monkeypatch.context() as patch:
        patch.setenv("URBANVOX_JIT", "0")
        expected = NodeRoles.of(model, *box)
    for name in ("on_block", "on_ground", "foot", "fixed_axes", "movable"):
        assert np.array_equal(getattr(got, name), getattr(expected, name)), name
    assert expected.foot.any() and expected.fixed_axes.any() and expected.movable.any()
    assert not expected.movable.all() and (expected.fixed_axes.sum(axis=1) == 1).any()


@pytest.mark.parametrize("seed", range(3))
def test_the_edge_table_is_numpys(monkeypatch, kernel, seed):
    from core import jit, smooth

    model, _, rng = shaken_blocks(seed)
    # A block surface's faces, numbered from 0 as CatmullClarkStep numbers them, and
    # random faces with repeated corners, faces given twice and unused nodes.
    _, faces = smooth.unique_nodes(model.quads, len(model.nodes))
    cases = [(faces.reshape(-1, 4), int(faces.max()) + 1),
             (rng.integers(0, 50, (400, 4)).astype(np.int32), 60)]
    for faces, size in cases:
        faces = np.concatenate([faces, faces[:7]])
        compiled_ends = kernel.undirected_edges(faces, size)
        monkeypatch.setattr(jit, "run", lambda *args, **kwargs: None)
        numpy_ends = smooth.undirected_edges(faces, size)
        monkeypatch.undo()
        assert numpy_ends.dtype == compiled_ends.dtype and np.array_equal(numpy_ends, compiled_ends)
        pairs = numpy_ends.reshape(-1, 2)
        assert (pairs[:, 0] <= pairs[:, 1]).all() and len(np.unique(pairs, axis=0)) == len(pairs)
