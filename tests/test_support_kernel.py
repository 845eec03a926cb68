"""The elimination's support test: the compiled kernel (core.support_kernel)
against the KD-tree searches (core.eliminate), and both against a brute
force over every data point."""
import numpy as np
import pytest

from core.classify import AIR, BUILDING, GROUND
from core.eliminate import (_ball_2d, _ball_3d, _ball_top, above_by_kind, eliminate_unsupported, supported_above,
                            supported_near)
from core.grid import VoxelGrid
from core.neighbours import search_tree


@pytest.fixture
def kernel(compiled):
    return compiled("support_kernel")


def in_chunks(test):
    """``test`` run on blocks of 100 faces: its (faces x points) tables stay small."""
    def run(points, centre, axis, h, support):
        return np.concatenate([test(points, centre[i:i + 100], axis[i:i + 100], h, support)
                               for i in range(0, len(centre), 100)])
    return run


@in_chunks
def brute_near(points, centre, axis, h, support):
    """Any point strictly in the ball (scipy's bound) within the support distance of the square."""
    d = [points[None, :, c] - centre[:, None, c] for c in range(3)]
    r = _ball_3d(h, support)
    in_ball = (d[0] * d[0] + d[1] * d[1]) + d[2] * d[2] < r * r
    term = [np.where(axis[:, None] == c, np.abs(d[c]), np.maximum(np.abs(d[c]) - 0.5 * h, 0.0)) for c in range(3)]
    zone = (term[0] * term[0] + term[1] * term[1]) + term[2] * term[2] <= (support * h) * (support * h)
    return (in_ball & zone).any(axis=1)


@in_chunks
def brute_above(points, centre, axis, h, support):
    """Walls: across the wall, along it past its edge; tops (axis 2): past the square's edges in
    plan; each kind in its own ball."""
    dx = np.abs(points[None, :, 0] - centre[:, None, 0])
    dy = np.abs(points[None, :, 1] - centre[:, None, 1])
    top = axis[:, None] == 2
    r = np.where(top, _ball_top(h, support), _ball_2d(h, support))
    in_ball = dx * dx + dy * dy < r * r
    past_x, past_y = np.maximum(dx - 0.5 * h, 0.0), np.maximum(dy - 0.5 * h, 0.0)
    across = np.where(top, past_x, np.where(axis[:, None] == 0, dx, dy))
    along = np.where(top, past_y, np.where(axis[:, None] == 0, past_y, past_x))
    above = points[None, :, 2] >= centre[:, None, 2] - 0.5 * h
    return (in_ball & above & (across * across + along * along <= (support * h) * (support * h))).any(axis=1)


def faces_around(rng, points, n, h, lattice=False):
    """Face centres and axes near the data (on a lattice of half voxels if ``lattice``)."""
    centre = points[rng.integers(0, len(points), n)] + rng.normal(scale=0.7 * h, size=(n, 3))
    if lattice:
        centre = np.round(centre / (0.5 * h)) * (0.5 * h)
    return centre, rng.integers(0, 3, n)


@pytest.mark.parametrize("h,support,spacing", [(1.0, 0.6, 0.3), (0.5, 0.6, 0.05), (1.0, 0.3, 0.5)])
def test_same_answers_as_the_tree_and_a_brute_force(kernel, h, support, spacing):
    # Roofs, walls and scattered points; the dense case puts far more than
    # 16 points in a face's ball, so the tree's search must widen.
    rng = np.random.default_rng(int(spacing * 100))
    side = min(20.0, 200 * spacing)
    n_roof = int((side / spacing) ** 2)
    roof = np.column_stack([rng.uniform(0, side, n_roof), rng.uniform(0, side, n_roof),
                            8 + rng.normal(0, 0.05, n_roof)])
    n_wall = int(side * 8 / spacing**2)
    wall = np.column_stack([np.full(n_wall, side / 2) + rng.normal(0, 0.05, n_wall), rng.uniform(0, side, n_wall),
                            rng.uniform(0, 8, n_wall)])
    points = np.concatenate([roof, wall, rng.uniform(0, side, (300, 3)) * [1, 1, 8 / side]])
    centre, axis = faces_around(rng, points, 4000, h)
    expected = brute_near(points, centre, axis, h, support)
    assert 0.05 < expected.mean() < 0.95  # both answers are common
    index = kernel.ColumnIndex(points, 1.5 * h)
    ball = _ball_3d(h, support)
    assert np.array_equal(supported_near(search_tree(points), points, centre, axis, h, support), expected)
    assert np.array_equal(kernel.supported_near(index, centre, axis, h, support, ball), expected)
    expected = brute_above(points, centre, axis, h, support)
    for faces in (axis < 2, axis == 2):
        assert 0.05 < expected[faces].mean() < 0.95
    tree_2d = search_tree(points[:, :2])
    got = above_by_kind(lambda c, a, ball: supported_above(tree_2d, points, c, a, h, support, ball), centre, axis, h,
                     support)
    assert np.array_equal(got, expected)
    got = above_by_kind(lambda c, a, ball: kernel.supported_above(index, c, a, h, support, ball), centre, axis, h,
                     support)
    assert np.array_equal(got, expected)


def test_points_on_the_bounds_of_the_ball_and_the_zone(kernel):
    # Points and faces on a lattice: points exactly at the support distance
    # (inside the zone, as <= has it) and exactly on the ball's bound
    # (outside, as the KD-tree's strict bound has it).
    h, support = 1.0, 0.5
    rng = np.random.default_rng(3)
    points = np.round(rng.uniform(0, 8, (3000, 3)) * 4) / 4
    centre, axis = faces_around(rng, points, 20_000, h, lattice=True)
    expected = brute_near(points, centre, axis, h, support)
    index = kernel.ColumnIndex(points, 1.5 * h)
    assert np.array_equal(supported_near(search_tree(points), points, centre, axis, h, support), expected)
    assert np.array_equal(kernel.supported_near(index, centre, axis, h, support, _ball_3d(h, support)), expected)
    expected = brute_above(points, centre, axis, h, support)
    got = above_by_kind(lambda c, a, ball: kernel.supported_above(index, c, a, h, support, ball), centre, axis, h,
                     support)
    assert np.array_equal(got, expected)
    tree_2d = search_tree(points[:, :2])
    got = above_by_kind(lambda c, a, ball: supported_above(tree_2d, points, c, a, h, support, ball), centre, axis, h,
                     support)
    assert np.array_equal(got, expected)


def test_a_point_on_the_ball_is_out_and_a_point_on_the_zone_is_in(kernel):
    # Distances exact in binary: with support 0.25 the 3-D ball has radius
    # 0.75, and a point at (0.25, 0.5, 0.5) from the centre of a face across
    # x is on it (out, as the KD-tree's strict bound has it) and on the
    # zone's bound (0.25 across, at the square's corner: in). With support
    # 0.375 the plan ball has radius 0.625 and (0.375, 0.5) is on both. A
    # quarter nearer along y, the points are in.
    h = 1.0
    centre, axis = np.zeros((1, 3)), np.array([0])
    for y, expected in ((0.5, False), (0.25, True)):
        support, points = 0.25, np.array([[0.25, y, 0.5]])
        index = kernel.ColumnIndex(points, 1.5 * h)
        assert brute_near(points, centre, axis, h, support).tolist() == [expected]
        assert supported_near(search_tree(points), points, centre, axis, h, support).tolist() == [expected]
        assert kernel.supported_near(index, centre, axis, h, support, _ball_3d(h, support)).tolist() == [expected]
        support, points = 0.375, np.array([[0.375, y, 2.0]])
        index = kernel.ColumnIndex(points, 1.5 * h)
        assert brute_above(points, centre, axis, h, support).tolist() == [expected]
        got = supported_above(search_tree(points[:, :2]), points, centre, axis, h, support)
        assert got.tolist() == [expected]
        got = kernel.supported_above(index, centre, axis, h, support, _ball_2d(h, support))
        assert got.tolist() == [expected]
    # Half a voxel below the face's centre is still above it; lower is not.
    for z, expected in ((-0.5, True), (-0.5 - 1e-9, False)):
        points = np.array([[0.5, 0.0, z]])
        index = kernel.ColumnIndex(points, 1.5 * h)
        got = kernel.supported_above(index, centre, axis, h, 0.5, _ball_2d(h, 0.5))
        assert got.tolist() == [expected]
        got = supported_above(search_tree(points[:, :2]), points, centre, axis, h, 0.5)
        assert got.tolist() == [expected]


def test_a_supporting_point_behind_many_nearer_ones_counts():
    # 40 points nearer to the face's centre than the supporting one, all
    # 0.3 in front of the face (past the support distance): the 16 nearest
    # do not decide, the widened search finds the point.
    h, support = 1.0, 0.2
    in_front = np.column_stack([np.full(40, 0.3), np.linspace(-0.3, 0.3, 40), np.zeros(40)])
    support_point = np.array([[0.15, 0.45, 0.45]])  # 0.15 in front, over the square
    points = np.concatenate([in_front, support_point])
    centre, axis = np.zeros((1, 3)), np.array([0])
    assert np.linalg.norm(support_point) > np.linalg.norm(in_front, axis=1).max()
    assert np.linalg.norm(support_point) < _ball_3d(h, support)
    assert supported_near(search_tree(points), points, centre, axis, h, support).tolist() == [True]
    assert supported_near(search_tree(in_front), in_front, centre, axis, h, support).tolist() == [False]


def partly_supported_block():
    """Grid (0.5 m voxels), labels and data of a block whose data covers part of its faces."""
    h = 0.5
    g = VoxelGrid(np.zeros(3), np.zeros(3), h, (24, 24, 16))
    labels = np.full(g.shape, AIR, np.uint8)
    labels[:, :, 0] = GROUND
    labels[4:20, 4:20, 1:12] = BUILDING
    rng = np.random.default_rng(5)
    roof = np.column_stack([rng.uniform(2.5, 9, 4000), rng.uniform(2, 9.5, 4000), np.full(4000, 5.6)])
    wall = np.column_stack([np.full(2000, 2.3), rng.uniform(2, 10, 2000), rng.uniform(0.5, 5.5, 2000)])
    return g, labels, np.concatenate([roof, wall])


def test_the_elimination_removes_the_same_voxels_with_the_kernel(kernel):
    # Elimination passes and all.
    g, labels, points = partly_supported_block()
    h = g.voxel_size
    for extrude in (False, True):
        numpy_labels, kernel_labels = labels.copy(), labels.copy()
        removed = eliminate_unsupported(numpy_labels, g, points, extrude_roofs=extrude, search=search_tree(points))
        assert len(removed) > 0
        index = kernel.ColumnIndex(points, 1.5 * h)
        assert np.array_equal(eliminate_unsupported(kernel_labels, g, points, extrude_roofs=extrude, search=index),
                              removed)
        assert np.array_equal(kernel_labels, numpy_labels)


def test_the_elimination_reports_its_share_done_block_by_block(monkeypatch):
    # Blocks of 100 faces: the first pass reports after each up to its share,
    # each later pass takes half of what is left; the voxels removed are the same.
    import core.eliminate as eliminate

    g, labels, points = partly_supported_block()
    flat, shape = labels.reshape(-1), np.array(g.shape)
    faces = len(eliminate.boundary_faces(flat, shape)[0])
    expected = labels.copy()
    removed = eliminate_unsupported(expected, g, points, extrude_roofs=True, search=search_tree(points))
    monkeypatch.setattr(eliminate, "_FACES", 100)
    shares = []
    got = eliminate_unsupported(labels, g, points, extrude_roofs=True, search=search_tree(points),
                                progress=shares.append)
    assert np.array_equal(got, removed) and np.array_equal(labels, expected)
    first = -(-faces // 100)  # blocks of the first pass
    assert faces > 900 and shares[:first] == pytest.approx(eliminate.FIRST_PASS_SHARE * np.minimum(
        np.arange(1, first + 1) * 100, faces) / faces)
    later = shares[first:]
    assert later and shares == sorted(shares) and shares[-1] < 1.0


def test_a_gap_in_the_roof_points_takes_one_voxel_not_a_well():
    """Airborne roof points 0.55 below the block's top, none within a voxel of the centre of column
    (3, 2): its top voxel goes (no point within 0.6 of its top face); the voxel below is under the
    roof points around it (0.5 past its square's edges, above it) and stays. Each later pass took
    the next voxel down before, a well to the ground; its faces, though, are left to the near test
    without the airborne rule (mesh data) and the well is dug."""
    g = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (8, 6, 8))
    labels = np.full(g.shape, AIR, np.uint8)
    labels[:, :, 0] = GROUND
    labels[1:7, 1:5, 1:6] = BUILDING
    xs, ys = np.meshgrid(np.arange(1.05, 7, 0.1), np.arange(1.05, 5, 0.1), indexing="ij")
    roof = np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, 5.45)])
    roof = roof[(np.abs(roof[:, 0] - 3.5) > 1.0) | (np.abs(roof[:, 1] - 2.5) > 1.0)]
    airborne = labels.copy()
    removed = eliminate_unsupported(airborne, g, roof, extrude_roofs=True, search=search_tree(roof))
    assert np.column_stack(np.unravel_index(removed, g.shape)).tolist() == [[3, 2, 5]]
    removed = eliminate_unsupported(labels, g, roof, search=search_tree(roof))
    assert [3, 2, 1] in np.column_stack(np.unravel_index(removed, g.shape)).tolist()


def test_no_data_supports_no_face():
    # A 2-voxel building and no building point: both voxels go, whatever search is given.
    g = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (1, 1, 4))
    labels = np.full(g.shape, AIR, np.uint8)
    labels[0, 0, 0], labels[0, 0, 1:3] = GROUND, BUILDING
    none = np.zeros((0, 3))
    for search in (None, search_tree(none)):
        for extrude in (False, True):
            removed = labels.copy()
            assert len(eliminate_unsupported(removed, g, none, extrude_roofs=extrude, search=search)) == 2
            assert (removed[0, 0, 1:] == AIR).all()


def test_a_failing_kernel_leaves_the_elimination_to_numpy(kernel, monkeypatch):
    # The kernel off after its failure (core.jit.run): the index's KD-tree
    # takes over, the same voxels go, with a warning.
    from core import jit

    def broken(*args):
        raise RuntimeError("cannot load the cache")

    g, labels, points = partly_supported_block()
    expected = labels.copy()
    removed = eliminate_unsupported(expected, g, points, extrude_roofs=True, search=search_tree(points))
    monkeypatch.setattr(kernel, "supported_near", broken)
    monkeypatch.setattr(jit, "failures", [])
    monkeypatch.setitem(jit._loaded, "support_kernel", kernel)  # put back as it was afterwards
    index = kernel.ColumnIndex(points, 1.5 * g.voxel_size)
    with pytest.warns(RuntimeWarning, match="support_kernel off"):
        got = eliminate_unsupported(labels, g, points, extrude_roofs=True, search=index)
    assert len(removed) > 0 and np.array_equal(got, removed)
    assert np.array_equal(labels, expected)
    assert index.fallback is not None and len(jit.failures) == 1


def random_labels(seed: int) -> np.ndarray:
    """Labels of a random grid, building cells on its borders too (faces out of the grid are not air)."""
    rng = np.random.default_rng(seed)
    shape = tuple(int(v) for v in rng.integers(1, 30, 3))
    return rng.choice(np.array([GROUND, BUILDING, AIR], np.uint8), shape, p=[0.2, 0.5, 0.3])


def same_faces(got, expected) -> None:
    for a, b in zip(got, expected):
        assert a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b)


@pytest.mark.parametrize("seed", range(6))
def test_boundary_faces_are_numpys(with_numpy, kernel, seed):
    """The scan of the labels finds the faces numpy finds from the list of
    every building cell (core.eliminate.air_faces), in its order."""
    from core.eliminate import air_faces, boundary_faces

    labels = random_labels(seed)
    flat, shape = labels.reshape(-1), np.array(labels.shape)
    expected = air_faces(flat, np.flatnonzero(flat == BUILDING), shape)
    same_faces(with_numpy(boundary_faces, flat, shape), expected)
    same_faces(kernel.boundary_faces(flat, shape, BUILDING, AIR), expected)
    assert len(expected[0]) > 0 or not (flat == BUILDING).any()


@pytest.mark.parametrize("seed", range(6))
def test_exposed_faces_are_numpys_and_those_the_removals_made(with_numpy, kernel, seed):
    """Some building cells of a random grid turned to air: the faces their
    removal exposed (kernel and numpy alike) are the building/air faces
    after it that were not there before, each once."""
    from core.eliminate import boundary_faces, exposed_faces

    labels = random_labels(seed)
    flat, shape = labels.reshape(-1), np.array(labels.shape)
    before = with_numpy(boundary_faces, flat, shape)
    building = np.flatnonzero(flat == BUILDING)
    gone = np.sort(np.random.default_rng(seed).choice(building, len(building) // 5, replace=False))
    flat[gone] = AIR
    expected = with_numpy(exposed_faces, flat, gone, shape)
    same_faces(kernel.exposed_faces(flat, gone, shape, BUILDING), expected)

    def as_set(faces):
        cells, axis, sign = faces
        return set(map(tuple, np.column_stack([cells, axis, sign]).tolist()))

    after = with_numpy(boundary_faces, flat, shape)
    new = as_set(after) - as_set(before)
    assert len(expected[1]) == len(new) and as_set(expected) == new and len(gone) > 0
