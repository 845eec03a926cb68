"""Voxel model steps (§2-3.4) on small grids with known answers."""
import re

import numpy as np
import pytest
from scipy import ndimage

from core.blocks import block_attributes, label_blocks, small_blocks
from core.classify import AIR, BUILDING, GROUND, classify_voxels, roof_hole_columns
from core.eliminate import eliminate_unsupported
from core.errors import UrbanvoxError
from core.grid import VoxelGrid
from core.ground import column_ground_level
from core.manifold import make_well_composed, repair_height_field
from core.memory import check_memory
from core.surface import AIR_REGION, GROUND_REGION, SurfaceModel, region_volume
from core.topology import check_surface, signed_volume


def box_shell_points(lo, hi, spacing):
    """Points on the six faces of an axis-aligned box (an STL-like closed surface)."""
    axes = [np.arange(lo[a], hi[a] + 1e-9, spacing) for a in range(3)]
    pts = []
    for a in range(3):
        b, c = [x for x in range(3) if x != a]
        gb, gc = np.meshgrid(axes[b], axes[c], indexing="ij")
        for value in (lo[a], hi[a]):
            p = np.zeros((gb.size, 3))
            p[:, a] = value
            p[:, b] = gb.ravel()
            p[:, c] = gc.ravel()
            pts.append(p)
    return np.concatenate(pts)


def grid_of(shape, h=1.0):
    return VoxelGrid(np.zeros(3), np.zeros(3), h, shape)


def test_closed_shell_with_inner_surface_becomes_one_solid_block():
    # A 6 x 4 x 5 box on flat ground at z = 1.0, plus an inner wall: the paper's
    # figure 2b. The interior (not reachable by the air) must become building.
    g = grid_of((12, 10, 10))
    shell = box_shell_points((3.0, 3.0, 1.0), (9.0, 7.0, 6.0), 0.1)
    inner = box_shell_points((6.0, 3.0, 1.0), (6.0, 7.0, 6.0), 0.1)
    cells = np.unique(g.cell_of(np.concatenate([shell, inner])), axis=0)
    ground_top = np.zeros((12, 10), np.int64)  # voxels k = 0 are ground (z < 1)
    labels = classify_voxels(g, ground_top, cells)
    blocks, n = label_blocks(labels)
    assert n == 1
    # x in [3, 9] -> cells 3..9, y 3..7, z 1..6 (the top face at z = 6 lies in k = 6)
    assert (labels[3:10, 3:8, 1:7] == BUILDING).all()
    assert np.count_nonzero(labels == BUILDING) == 7 * 5 * 6
    assert (labels[:, :, 0] == GROUND).all()
    assert np.count_nonzero(labels == AIR) == 12 * 10 * 10 - 12 * 10 - 7 * 5 * 6


def test_gap_between_ground_and_roof_becomes_building():
    g = grid_of((3, 3, 8))
    roof = np.array([[1, 1, 5]])
    labels = classify_voxels(g, np.full((3, 3), 1), roof)
    assert list(labels[1, 1]) == [GROUND, GROUND, BUILDING, BUILDING, BUILDING, BUILDING, AIR, AIR]
    assert (labels[0, 0, 2:] == AIR).all()


def test_ground_has_priority_over_building_points():
    g = grid_of((2, 2, 6))
    labels = classify_voxels(g, np.full((2, 2), 2), np.array([[0, 0, 1], [0, 0, 2]]))
    assert not (labels == BUILDING).any()


def test_roof_hole_is_filled_but_courtyard_and_yard_tree_are_not():
    n = 30
    building = np.zeros((n, n), bool)
    ground = np.ones((n, n), bool)
    # building ring 4..25 with a 2x2 hole (no return) and a 10x10 courtyard (ground returns)
    building[4:26, 4:26] = True
    ground[4:26, 4:26] = False
    building[8:10, 8:10] = False            # roof hole, no return
    building[12:22, 12:22] = False          # courtyard
    ground[12:22, 12:22] = True
    ground[27:29, 1:3] = False              # tree in the yard: no ground return
    top = np.where(building, 12, 0)
    seeds = roof_hole_columns(building, ground, top, max_hole_cells=50)
    assert sorted(map(tuple, seeds[:, :2])) == [(8, 8), (8, 9), (9, 8), (9, 9)]
    assert (seeds[:, 2] == 12).all()


def test_ground_level_is_interpolated_under_roofs():
    g = grid_of((20, 20, 30), h=1.0)
    x, y = np.meshgrid(np.arange(20) + 0.5, np.arange(20) + 0.5, indexing="ij")
    z = 5.0 + 0.1 * x + 0.05 * y
    roof = (x > 6) & (x < 14) & (y > 6) & (y < 14)
    pts = np.column_stack([x[~roof], y[~roof], z[~roof]])
    level = column_ground_level(g, pts)
    assert np.allclose(level.z, z, atol=1e-9)          # a plane is interpolated exactly
    assert not level.observed[roof].any()
    # voxel (i, j, k) is ground when its centre k + 0.5 <= z
    assert np.array_equal(level.top_k, np.floor(z - 0.5).astype(int))


@pytest.mark.parametrize("kernels", ["0", "always"])
def test_ground_level_from_world_coordinates_is_bit_for_bit_the_local_one(kernels, monkeypatch):
    # The tiled run hands the domain's world points over, shifted to local
    # coordinates a chunk at a time (numpy) or point by point (compiled,
    # core.grid_kernel.local_columns): every number must be the local run's.
    from core.grid import VoxelGrid
    from core.ground import _local_columns
    monkeypatch.setenv("URBANVOX_JIT", kernels)
    rng = np.random.default_rng(3)
    offset = np.array([2.6e6 + 0.37, 1.2e6 + 0.11, 41.3])
    g = VoxelGrid(offset, np.zeros(3), 0.7, (40, 30, 60))
    pts = offset + rng.uniform([0, 0, 5], [28, 21, 9], size=(2000, 3))  # columns left empty too
    local = column_ground_level(g, pts - offset)
    world = column_ground_level(g, pts, world=True)
    assert not local.observed.all()
    assert np.array_equal(world.z, local.z)
    assert np.array_equal(world.top_k, local.top_k)
    assert np.array_equal(world.observed, local.observed)
    column, height = _local_columns(g, pts, chunk=7)  # numpy: many chunks, a short last one
    assert np.array_equal(column, g.column_of(pts - offset))
    assert np.array_equal(height, (pts - offset)[:, 2])


def test_ground_ceiling_bounds_every_column_from_above():
    from core.ground import column_ceiling

    rng = np.random.default_rng(2)
    g = grid_of((30, 20, 10), h=1.0)
    pts = np.column_stack([rng.random((5000, 2)) * [30, 20], 3 + rng.gamma(0.5, 0.3, 5000)])
    ceiling = column_ceiling(g, pts)
    column = g.column_of(pts)
    highest = np.full(30 * 20, -np.inf)
    np.maximum.at(highest, column, pts[:, 2])
    assert (ceiling.ravel() >= highest).all()
    assert np.isneginf(ceiling.ravel()[np.bincount(column, minlength=600) == 0]).all()
    assert np.median(ceiling.ravel() - highest) < 1.0  # a bound that prunes: within a metre


def test_memory_guard_refuses_before_allocating():
    with pytest.raises(UrbanvoxError, match="voxel size of at least"):
        check_memory((20000, 20000, 300), 0.25, available=8 * 2**30)


def test_memory_guard_counts_the_points_and_suggests_what_fits():
    # 10 M points take 480 MB at any voxel size: the voxel size and the tile
    # suggested fit in what they leave, points and halo included.
    shape, available, points = (2000, 2000, 100), 2 * 2**30, 10**7
    with pytest.raises(UrbanvoxError, match=r"with its 10000000 points needs about 4\.2 GiB") as error:
        check_memory(shape, 0.5, available=available, bytes_per_voxel=10, tile_hint=True, points=points)
    size = float(re.search(r"voxel size of at least ([\d.]+)", str(error.value)).group(1))
    coarser = tuple(int(np.ceil(n * 0.5 / size)) for n in shape)
    check_memory(coarser, size, available=available, bytes_per_voxel=10, points=points)
    tile = float(re.search(r"tiles of at most ([\d.]+)", str(error.value)).group(1))
    side = int(tile / 0.5) + 24
    check_memory((side, side, 100), 0.5, available=available, bytes_per_voxel=10,
                 points=points * side * side // (shape[0] * shape[1]))
    # Points beyond the memory whatever the voxels, or leaving too little for any grid: no
    # voxel size is suggested.
    with pytest.raises(UrbanvoxError, match="The points alone need 4.5 GiB: use a smaller area") as error:
        check_memory((10, 10, 10), 1.0, available=2**30, points=10**8)
    assert "voxel size of at least" not in str(error.value)
    with pytest.raises(UrbanvoxError, match="The points alone need 1.00 GiB: use a smaller area"):
        check_memory((4000, 4000, 100), 1.0, available=2**30, bytes_per_voxel=10, points=(2**30 - 1) // 48)
    with pytest.raises(UrbanvoxError, match="must be a positive number of bytes"):
        check_memory((10, 10, 10), 1.0, available=0)


def test_height_field_repair_removes_diagonal_patterns():
    rng = np.random.default_rng(1)
    top = rng.integers(0, 6, size=(40, 40))
    fixed = repair_height_field(top)
    assert (fixed >= top).all()
    a, b, c, d = fixed[:-1, :-1], fixed[1:, :-1], fixed[1:, 1:], fixed[:-1, 1:]
    assert not (np.minimum(a, c) > np.maximum(b, d)).any()
    assert not (np.minimum(b, d) > np.maximum(a, c)).any()


def random_model(seed, shape=(24, 22, 14)):
    """Random ground and random building blobs: the worst case for manifoldness."""
    rng = np.random.default_rng(seed)
    g = grid_of(shape)
    top = repair_height_field(rng.integers(0, 3, size=shape[:2]))
    cells = np.argwhere(rng.random(shape) < 0.06)
    cells = cells[cells[:, 2] < shape[2] - 2]
    labels = classify_voxels(g, top, cells)
    make_well_composed(labels)
    return g, labels


def repaired_both_ways(seed):
    """A random model's labels after the drop of its small blocks and the
    removal of random building voxels next to the air (as the elimination
    removes them), repaired on the whole grid and around the removed voxels;
    the voxels each repair filled."""
    from core.blocks import blocks_above_thresholds
    from core.manifold import _all_critical_cubes

    g, labels = random_model(seed)
    blocks_above_thresholds(labels, g, 2.5, 2.0, 3.0)
    assert len(_all_critical_cubes(labels)) == 0  # dropping whole blocks keeps the labels well-composed
    rng = np.random.default_rng(seed)
    near_air = ndimage.binary_dilation(labels == AIR) & (labels == BUILDING)
    removed = np.flatnonzero(near_air & (rng.random(labels.shape) < 0.3))
    labels.reshape(-1)[removed] = AIR
    whole, around = labels.copy(), labels.copy()
    added = (make_well_composed(whole), make_well_composed(around, changed=removed))
    assert len(_all_critical_cubes(around)) == 0
    return whole, around, added


@pytest.mark.parametrize("seed", range(6))
def test_repair_around_changed_voxels_fills_what_the_whole_grid_repair_fills(seed):
    # The pipeline repairs after the elimination only around the voxels it
    # removed, the labels being well-composed before.
    whole, around, (added_whole, added_around) = repaired_both_ways(seed)
    assert added_around == added_whole and np.array_equal(around, whole)


def test_repair_around_changed_voxels_has_work_to_do():
    # The cases above are not trivial: most of them fill voxels.
    assert sum(repaired_both_ways(seed)[2][0] > 0 for seed in range(6)) >= 4


@pytest.mark.parametrize("seed", range(6))
def test_every_region_surface_is_closed_manifold_and_conforming(seed):
    g, labels = random_model(seed)
    blocks, n = label_blocks(labels)
    assert n > 0
    regions = region_volume(labels, blocks)
    # The same ids written into the block grid itself, which the pipeline gives up.
    given_up = blocks.copy()
    in_place = region_volume(labels, given_up, overwrite_blocks=True)
    assert in_place is given_up and np.array_equal(in_place, regions)
    assert np.array_equal(blocks[labels == BUILDING], regions[labels == BUILDING])
    model = SurfaceModel.from_regions(g, regions)
    # Conforming: every face separates two different regions and no face is duplicated.
    assert (model.regions[:, 0] != model.regions[:, 1]).all()
    assert len(np.unique(np.sort(model.quads, axis=1), axis=0)) == len(model.quads)
    total = 0.0
    for r in list(range(1, n + 1)) + [GROUND_REGION, AIR_REGION]:
        quads = model.closed_surface(r)
        report = check_surface(quads)
        assert report.ok, (r, report)
        vol = signed_volume(model.nodes, quads)
        assert vol == pytest.approx(np.count_nonzero(regions == r))  # outward, exact
        total += vol
    assert total == pytest.approx(np.prod(g.shape))
    # The air is one volume (paper §3 assumption) and so is the ground.
    air, n_air = ndimage.label(labels == AIR, structure=ndimage.generate_binary_structure(3, 1))
    assert n_air == 1


def test_block_attributes_and_thresholds():
    g = grid_of((10, 10, 10), h=0.5)
    labels = np.full(g.shape, AIR, np.uint8)
    labels[:, :, 0] = GROUND
    labels[1:5, 1:3, 1:7] = BUILDING     # 4 x 2 columns, 6 voxels high
    labels[8, 8, 1:3] = BUILDING         # a shed: 1 column, 1 m high
    blocks, n = label_blocks(labels)
    t = block_attributes(blocks, n, g)
    assert n == 2
    assert t.volume.tolist() == [48 * 0.125, 2 * 0.125]
    assert t.footprint_area.tolist() == [8 * 0.25, 0.25]
    assert t.height.tolist() == [3.0, 1.0]
    assert t.ground_z.tolist() == [0.5, 0.5]
    assert small_blocks(t, 2.5, 1.0, 0.0).tolist() == [False, True]


def test_elimination_keeps_voxels_sharing_enough_volume():
    # Two walls of building voxels; data: the true facades. At x = 4.5 the voxel
    # x in [4, 5) is half inside: its face at 5 is 0.5 from the data, kept. At
    # x = 7.3 the voxel [7, 8) is 30 % inside: its face at 7 is 0.3 from... the
    # data lies at 7.3 on the low side: face 7 is 0.3 away, kept; the high side
    # voxels [9, 10) have their face at 10 one voxel from the facade at 9.0: gone.
    g = grid_of((12, 3, 6))
    labels = np.full(g.shape, AIR, np.uint8)
    labels[:, :, 0] = GROUND
    labels[2:5, :, 1:4] = BUILDING
    labels[7:10, :, 1:4] = BUILDING
    ys, zs = np.meshgrid(np.arange(0.05, 3, 0.1), np.arange(1.05, 4, 0.1), indexing="ij")

    def wall(x):
        return np.column_stack([np.full(ys.size, x), ys.ravel(), zs.ravel()])
    xs, yr = np.meshgrid(np.arange(0.05, 12, 0.1), np.arange(0.05, 3, 0.1), indexing="ij")
    roofs = np.column_stack([xs.ravel(), yr.ravel(), np.full(xs.size, 3.9)])
    roofs = roofs[((roofs[:, 0] > 2) & (roofs[:, 0] < 4.5)) | ((roofs[:, 0] > 7.3) & (roofs[:, 0] < 9.0))]
    pts = np.concatenate([wall(2.0), wall(4.5), wall(7.3), wall(9.0), roofs])
    before = labels.copy()
    removed = eliminate_unsupported(labels, g, pts)
    assert len(removed) == 3 * 3
    # The voxels it returns are those that became air, ascending.
    assert np.array_equal(removed, np.flatnonzero((before == BUILDING) & (labels == AIR)))
    assert (labels[9, :, 1:4] == AIR).all()
    assert (labels[2:5, :, 1:4] == BUILDING).all() and (labels[7:9, :, 1:4] == BUILDING).all()


def test_elimination_tests_the_voxels_it_exposes():
    # A column of voxels in front of a wall holds no data: the first pass
    # removes the ones facing the air, the next the one it exposed at the foot.
    g = grid_of((8, 1, 6))
    labels = np.full(g.shape, AIR, np.uint8)
    labels[:, :, 0] = GROUND
    labels[5, :, 1] = GROUND            # the ground steps up in front of the wall
    labels[2:5, :, 1:5] = BUILDING      # the building
    labels[5, :, 2:5] = BUILDING        # stray column of voxels in front of it
    zs = np.arange(1.05, 5, 0.1)
    wall = np.column_stack([np.full(zs.size, 5.0), np.full(zs.size, 0.5), zs])
    xs = np.arange(2.05, 5, 0.1)
    roof = np.column_stack([xs, np.full(xs.size, 0.5), np.full(xs.size, 4.95)])
    other = np.column_stack([np.full(zs.size, 2.0), np.full(zs.size, 0.5), zs])
    eliminate_unsupported(labels, g, np.concatenate([wall - [0.001, 0, 0], roof, other]))
    assert (labels[5, 0, 2:5] == AIR).all()
    assert (labels[2:5, 0, 1:5] == BUILDING).all()


def test_airborne_walls_are_supported_by_the_roof_edge_above():
    def model():
        g = grid_of((8, 3, 8))
        labels = np.full(g.shape, AIR, np.uint8)
        labels[:, :, 0] = GROUND
        labels[2:6, :, 1:6] = BUILDING
        return g, labels
    xs, ys = np.meshgrid(np.arange(2.05, 6, 0.1), np.arange(0.05, 3, 0.1), indexing="ij")
    roof = np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, 5.8)])
    g, labels = model()
    assert len(eliminate_unsupported(labels, g, roof, extrude_roofs=True)) == 0
    # Without the extrusion rule every wall voxel below the roof voxel would go.
    g, labels = model()
    assert len(eliminate_unsupported(labels, g, roof, extrude_roofs=False)) > 0
    assert (labels[2, :, 1:5] == AIR).all()


def box_city(rng, shape):
    """Ground, then random building and air boxes: eaves, bridges, sealed rooms."""
    labels = np.full(shape, AIR, np.uint8)
    labels[:, :, 0] = GROUND
    for _ in range(rng.integers(1, 12)):
        lo = rng.integers(0, shape)
        hi = lo + rng.integers(1, 5, 3)
        labels[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]] = rng.choice([BUILDING, AIR], p=[0.8, 0.2])
    return labels


def test_enclosed_air_is_what_a_front_from_the_top_row_misses():
    import core.classify as classify

    rng = np.random.default_rng(7)
    hollow = 0
    for _ in range(400):
        labels = box_city(rng, tuple(rng.integers(2, 12, 3)))
        # Reference: the paper's front, as a labelling of all the air.
        components, _ = ndimage.label(labels == AIR, structure=ndimage.generate_binary_structure(3, 1))
        top = np.unique(components[:, :, -1])
        enclosed = (components > 0) & ~np.isin(components, top[top > 0])
        covered = np.logical_or.accumulate(labels[:, :, ::-1] != AIR, axis=2)[:, :, ::-1] & (labels == AIR)
        hollow += np.count_nonzero(covered) > labels.size // classify._MOSTLY_COVERED
        expected = np.where(enclosed, BUILDING, labels)
        assert classify.enclose_air(labels) == np.count_nonzero(enclosed)
        assert np.array_equal(labels, expected)
    assert 50 < hollow < 350  # both ways of finding the pockets were taken


def test_critical_cubes_in_slabs_are_those_of_the_whole_grid(monkeypatch):
    import core.manifold as manifold

    rng = np.random.default_rng(3)
    labels = rng.integers(GROUND, AIR + 1, size=(9, 7, 6)).astype(np.uint8)
    # Reference: each cube's pattern code from its corners' label - 1 digits.
    code = sum((labels[di:di + 8, dj:dj + 6, dk:dk + 5].astype(int) - 1) * 3**bit
               for bit, (di, dj, dk) in enumerate(manifold.CORNERS))
    expected = np.flatnonzero(np.pad(manifold.FIX_TABLE[code] >= 0, ((0, 1), (0, 1), (0, 1))))
    assert len(expected) > 10
    monkeypatch.setattr(manifold, "_SLAB_CUBES", 60)  # two planes of cubes per slab
    assert np.array_equal(manifold._all_critical_cubes(labels), expected)


def test_dropping_blocks_keeps_the_labels_well_composed():
    import core.manifold as manifold
    from core.blocks import drop_blocks

    for seed in range(6):
        _, labels = random_model(seed, shape=(30, 26, 12))
        blocks, n = label_blocks(labels)
        assert n > 4
        dropped = np.arange(1, n + 1, 2)  # any blocks
        drop_blocks(labels, blocks, dropped)
        assert np.array_equal(np.unique(blocks[labels == BUILDING]), np.arange(2, n + 1, 2))
        assert len(manifold._all_critical_cubes(labels)) == 0


def test_block_attributes_match_a_count_per_block():
    g, labels = random_model(2, shape=(20, 18, 12))
    # A C-shaped block around a floating one: column (3, 3) holds A, B, A.
    labels[1:6, 1:6, 1:10] = AIR
    labels[3:6, 3, 1] = BUILDING
    labels[5, 3, 1:9] = BUILDING
    labels[2:6, 2:5, 8] = BUILDING
    labels[3, 3, 3:6] = BUILDING
    blocks, n = label_blocks(labels)
    t = block_attributes(blocks, n, g)
    for b in range(1, n + 1):
        i, j, k = np.nonzero(blocks == b)
        assert t.n_voxels[b - 1] == len(i)
        assert t.footprint_area[b - 1] == len(set(zip(i.tolist(), j.tolist()))) * g.voxel_size**2
        assert t.ground_z[b - 1] == g.origin[2] + k.min() * g.voxel_size
        assert t.top_z[b - 1] == g.origin[2] + (k.max() + 1) * g.voxel_size
    column = blocks[3, 3][blocks[3, 3] > 0]
    assert column[0] == column[-1] != column[3]  # the interleaved column is there


def test_kept_blocks_are_numbered_and_measured_as_a_new_labelling_does():
    from core.blocks import drop_blocks, keep_blocks

    for seed in range(4):
        g, labels = random_model(seed, shape=(30, 26, 12))
        if seed % 2:
            labels = np.asfortranarray(labels)  # changed in place in any memory order
        blocks, n = label_blocks(labels)
        table = block_attributes(blocks, n, g)
        keep = np.random.default_rng(seed).random(n) < 0.5
        drop_blocks(labels, blocks, table.block_id[~keep])
        kept, kept_table = keep_blocks(blocks, table, keep)
        relabelled, m = label_blocks(labels)
        assert m == keep.sum() and np.array_equal(kept, relabelled)
        fresh = block_attributes(relabelled, m, g)
        for name in ("block_id", "n_voxels", "volume", "footprint_area", "ground_z", "top_z"):
            assert np.array_equal(getattr(kept_table, name), getattr(fresh, name)), name
