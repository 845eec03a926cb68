"""Self-intersection control of projected surfaces (core.intersect)."""
import numpy as np
import pytest

from core.intersect import undo_crossings
from core.topology import touching


def two_plates(gap):
    """Two parallel unit squares (two quads), ``gap`` apart in z."""
    nodes = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                      [0, 0, gap], [1, 0, gap], [1, 1, gap], [0, 1, gap]], float)
    quads = np.array([[0, 1, 2, 3], [4, 5, 6, 7]])
    return nodes, quads


def test_a_node_pushed_through_the_plate_above_is_put_back():
    old, quads = two_plates(0.5)
    new = old.copy()
    new[0] = [0.3, 0.3, 1.0]          # through the upper plate
    moved = np.zeros(8, bool)
    moved[0] = True
    positions, kept, undone = undo_crossings(old, new, moved, quads)
    assert undone == 1 and not kept[0]
    assert np.array_equal(positions, old)


def test_moves_that_cross_nothing_are_kept():
    old, quads = two_plates(0.5)
    new = old.copy()
    new[0] = [0.0, 0.0, 0.2]          # rises, stays below the upper plate
    moved = np.zeros(8, bool)
    moved[0] = True
    positions, kept, undone = undo_crossings(old, new, moved, quads)
    assert undone == 0 and kept[0]
    assert np.array_equal(positions, new)


def test_neighbouring_faces_folded_along_their_edge_do_not_cross():
    # Two quads sharing an edge, the second folded up, then back over the
    # first, 5 cm above it: their triangles touch along the edge and at its
    # nodes, which is no crossing.
    old = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]], float)
    quads = np.array([[0, 1, 2, 3], [1, 4, 5, 2]])
    moved = np.zeros(len(old), bool)
    moved[[4, 5]] = True
    for folded in ([[1, 0, 1], [1, 1, 1]], [[0.2, 0, 0.05], [0.2, 1, 0.05]]):
        new = old.copy()
        new[[4, 5]] = folded
        positions, kept, undone = undo_crossings(old, new, moved, quads)
        assert undone == 0 and kept[[4, 5]].all()
        assert np.array_equal(positions, new)


def _reference_edges_cross(edges_of, faces):
    """Moller-Trumbore as first written, on (P, 3, 3) corner tables: whether
    an edge of each triangle in ``edges_of`` crosses the paired triangle."""
    v0, v1, v2 = faces[:, 0], faces[:, 1], faces[:, 2]
    e1, e2 = v1 - v0, v2 - v0
    hit = np.zeros(len(faces), dtype=bool)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        origin = edges_of[:, i]
        direction = edges_of[:, j] - origin
        h = np.cross(direction, e2)
        det = np.einsum("ij,ij->i", e1, h)
        ok = np.abs(det) > 1e-12 * np.maximum(np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1), 1e-300) \
            * np.maximum(np.linalg.norm(direction, axis=1), 1e-300)
        inv = np.divide(1.0, det, out=np.zeros_like(det), where=ok)
        s = origin - v0
        u = inv * np.einsum("ij,ij->i", s, h)
        q = np.cross(s, e1)
        v = inv * np.einsum("ij,ij->i", direction, q)
        t = inv * np.einsum("ij,ij->i", e2, q)
        eps = 1e-9
        hit |= ok & (u > eps) & (v > eps) & (u + v < 1 - eps) & (t > eps) & (t < 1 - eps)
    return hit


def _reference_undo(old, new, moved, quads, max_rounds=20):
    """undo_crossings as first written: every quad split again and every pair
    of a focus triangle with any other tested, every round (brute force)."""
    from core.quality import best_split

    positions, moved, undone, near = new.copy(), moved.copy(), 0, None
    for _ in range(max_rounds):
        triangles, _ = best_split(positions, quads)
        focus = moved[triangles].any(axis=1)
        if near is not None:
            centre = positions[triangles].mean(axis=1)
            focus &= np.all((centre >= near[0]) & (centre <= near[1]), axis=1)
        a, b = np.nonzero(focus[:, None] & ~np.eye(len(triangles), dtype=bool))
        shared = (triangles[a][:, :, None] == triangles[b][:, None, :]).any(axis=(1, 2))
        a, b = a[~shared], b[~shared]
        p = positions[triangles]
        crossing = _reference_edges_cross(p[a], p[b]) | _reference_edges_cross(p[b], p[a])
        if not crossing.any():
            break
        culprits = np.unique(triangles[np.concatenate([a[crossing], b[crossing]])])
        culprits = culprits[moved[culprits]]
        if len(culprits) == 0:
            break
        positions[culprits] = old[culprits]
        moved[culprits] = False
        undone += len(culprits)
        span = 4 * np.linalg.norm(np.ptp(positions[quads[0]], axis=0))
        near = (np.minimum(old[culprits], new[culprits]).min(axis=0) - span,
                np.maximum(old[culprits], new[culprits]).max(axis=0) + span)
    return positions, moved, undone


def stacked_grids(n=8, gap=0.3, layers=3):
    """``layers`` parallel n x n quad grids ``gap`` apart."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    plane = np.column_stack([i.ravel(), j.ravel()]).astype(float)
    nodes = np.concatenate([np.column_stack([plane, np.full(len(plane), z * gap)]) for z in range(layers)])
    a = (i[:-1, :-1] * (n + 1) + j[:-1, :-1]).ravel()
    cell = np.column_stack([a, a + n + 1, a + n + 2, a + 1])
    quads = np.concatenate([cell + z * (n + 1) ** 2 for z in range(layers)])
    return nodes, quads


@pytest.mark.parametrize("switch", ["1", "0"])
def test_undo_crossings_matches_the_brute_force_reference(monkeypatch, compiled, switch):
    # Three close layers shaken hard: 50 to 80 moves undone, in up to three
    # rounds; with the compiled crossing search (core.crossing_kernel, loaded
    # here: on its own it waits for a million quads) and without.
    monkeypatch.setenv("URBANVOX_JIT", switch)
    if switch == "1":
        compiled("crossing_kernel")
    old, quads = stacked_grids()
    for seed in range(6):
        rng = np.random.default_rng(seed)
        moved = rng.random(len(old)) < 0.5
        new = old.copy()
        new[moved] += rng.normal(scale=0.25, size=(moved.sum(), 3))
        expected = _reference_undo(old, new, moved, quads)
        positions, kept, undone = undo_crossings(old, new, moved, quads)
        assert undone == expected[2] > 0
        assert np.array_equal(kept, expected[1]) and np.array_equal(positions, expected[0])
        # The moves undone in the caller's array instead of a copy: the same rounds
        # (each after the first searches around what the last one undid, from where it was).
        given_up = new.copy()
        in_place, kept_too, undone_too = undo_crossings(old, given_up, moved, quads, overwrite_new=True)
        assert in_place is given_up and undone_too == undone
        assert np.array_equal(kept_too, kept) and np.array_equal(in_place, positions)


def test_a_quad_is_searched_with_the_reach_of_all_four_corners():
    # A kite whose fourth corner lies far from its centre, and a small
    # vertical plate that is pushed down through the kite next to that corner.
    nodes = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [-4, 5, 0],
                      [-3.1, 4, 0.1], [-2.9, 4, 0.1], [-2.9, 4, 0.5], [-3.1, 4, 0.5]], float)
    quads = np.array([[0, 1, 2, 3], [4, 5, 6, 7]])
    new = nodes.copy()
    new[[4, 5], 2] = -0.2
    moved = np.zeros(len(nodes), bool)
    moved[[4, 5]] = True
    positions, kept, undone = undo_crossings(nodes, new, moved, quads)
    assert undone == 2 and not kept[[4, 5]].any()
    assert np.array_equal(positions, nodes)


def test_near_cells_are_the_cells_around_the_seeds_with_a_table_or_a_sort():
    # _Cells.near marks the seeds' cells in a table when the grid of cells
    # is small, and sorts the keys otherwise: both give the faces whose cell
    # is at most one cell away from a seed's on every axis.
    from core.intersect import _Cells

    rng = np.random.default_rng(5)
    paths = set()
    for trial in range(60):
        n = int(rng.integers(1, 300))
        spread = [1, 10, 1000][trial % 3]  # dense grids take the table, sparse ones the sort
        centre = rng.random((n, 3)) * spread
        seeds = np.flatnonzero(rng.random(n) < 0.2)
        radius = 0.5
        cell = np.floor((centre - centre.min(axis=0)) / radius).astype(int)
        dims = cell.max(axis=0) + 3
        paths.add(bool(np.prod(dims) <= 4 * n))
        near = np.abs(cell[:, None, :] - cell[None, seeds, :]).max(axis=2) <= 1
        expected = np.flatnonzero(near.any(axis=1))
        assert np.array_equal(_Cells(centre, radius).near(seeds), expected)
    assert paths == {True, False}


def test_cells_placed_again_are_those_of_a_new_lattice_and_refuse_centres_outside_it():
    # undo_crossings keeps its lattice across rounds and places again only
    # the faces whose centre moved: the faces near the seeds are then those
    # a lattice made afresh over the new centres (with the same origin and
    # side) gives; a centre moved outside the lattice is refused, and the
    # caller makes a new one.
    from core.intersect import _Cells

    rng = np.random.default_rng(8)
    centre = rng.random((2000, 3)) * 20
    cells = _Cells(centre, 0.7)
    moved = rng.choice(len(centre), 50, replace=False)
    new_centre = centre.copy()
    new_centre[moved] = np.clip(centre[moved] + rng.normal(0, 2, (50, 3)), centre.min(axis=0), centre.max(axis=0))
    fresh = _Cells(new_centre, 0.7)  # within the old bounds: the old lattice's origin and size
    assert fresh.lowest == cells.lowest and np.array_equal(fresh.dims, cells.dims)
    assert cells.moved(moved, new_centre[moved])
    assert np.array_equal(cells.key, fresh.key)
    seeds = rng.choice(len(centre), 30, replace=False)
    assert np.array_equal(cells.near(seeds), fresh.near(seeds))
    before = cells.key.copy()
    assert not cells.moved(moved[:1], centre[moved[:1]] + 100)
    assert np.array_equal(cells.key, before)


def test_pairs_within_slabs_are_every_close_pair_once(monkeypatch):
    # The slab search cuts the members along x or y into chunks, each
    # searched with the band that follows it; crowded members (a wall across
    # the slab axis) are searched chunk against a tree of all. Either way
    # every pair within the radius comes exactly once, whatever the chunk,
    # with ties along the axis (a lattice) too.
    from core import intersect
    from core.intersect import _pairs_within

    by_chunks = []
    real = intersect._pairs_between

    def counted(centre, faces, members, others, *args):
        by_chunks.append(others is None)  # the members against themselves
        yield from real(centre, faces, members, others, *args)

    monkeypatch.setattr(intersect, "_pairs_between", counted)
    rng = np.random.default_rng(11)
    paths = set()
    for trial in range(36):
        n = int(rng.integers(2, 400))
        shape = [[200, 5, 5], [5, 200, 5], [0, 3, 5]][trial % 3]  # along x, along y, a wall
        centre = rng.random((n, 3)) * shape
        if trial % 4 == 0:
            centre = np.round(centre)  # many points share a coordinate
        faces = rng.permutation(n)  # the rows of centre the members' positions name
        members = np.sort(rng.choice(n, int(rng.integers(1, n + 1)), replace=False))
        marked = rng.random(n) < [1.0, 0.3][trial % 2]
        radius = float(rng.choice([0.5, 1.0, 1.5]))
        at = centre[faces[members]]
        close = np.linalg.norm(at[:, None] - at[None], axis=2) <= radius
        i, j = np.nonzero(np.triu(close, 1))
        i, j = members[i], members[j]
        keep = marked[i] | marked[j]
        expected = sorted(zip(i[keep].tolist(), j[keep].tolist()))
        for chunk in (1, 7, 1000):
            by_chunks.clear()
            found = [(min(p), max(p)) for a, b in _pairs_within(centre, faces, members, radius, chunk, None, marked)
                     for p in zip(a.tolist(), b.tolist())]
            assert sorted(found) == expected
            paths.add((any(by_chunks), chunk < len(members)))
    assert paths >= {(False, True), (True, True)}  # slabs and chunks, each with several parts


def test_close_pairs_hold_every_pair_of_a_seed_whose_balls_meet():
    # Faces of three sizes (three classes), some seeds: every pair of a seed
    # and another face whose balls meet is found, once; no pair without a seed.
    from core.intersect import _close_pairs

    rng = np.random.default_rng(12)
    for trial in range(12):
        n = int(rng.integers(5, 500))
        centre = rng.random((n, 3)) * 10
        reach = rng.choice([0.2, 0.6, 1.5], size=n, p=[0.85, 0.12, 0.03]) * rng.uniform(0.5, 1, n)
        faces = np.sort(rng.choice(n, n - n // 5, replace=False))
        seeds = np.flatnonzero(rng.random(len(faces)) < [0.9, 0.1][trial % 2])
        found = [(min(p), max(p)) for a, b in _close_pairs(centre, reach, faces, seeds, 16, None)
                 for p in zip(a.tolist(), b.tolist())]
        assert len(found) == len(set(found))
        is_seed = np.zeros(len(faces), bool)
        is_seed[seeds] = True
        assert all(is_seed[a] or is_seed[b] for a, b in found)
        c, r = centre[faces], reach[faces]
        meet = np.linalg.norm(c[:, None] - c[None], axis=2) < r[:, None] + r[None]
        i, j = np.nonzero(np.triu(meet, 1))
        wanted = {(a, b) for a, b in zip(i.tolist(), j.tolist()) if is_seed[a] or is_seed[b]}
        assert wanted <= set(found)


def test_edge_crossings_per_coordinate_match_the_corner_tables_bit_for_bit():
    # The narrow phase on one array per coordinate does numpy's (P, 3)
    # arithmetic: on near-degenerate pairs (edges grazing a triangle, at
    # every scale) its answers equal the tables' ones exactly.
    from core.intersect import _edges_cross
    from core.vectors import coordinates

    rng = np.random.default_rng(8)
    nodes = rng.normal(size=(3000, 3)) * 10.0 ** rng.integers(-6, 4, size=(3000, 1))
    tri = rng.integers(0, 3000, size=(200_000, 3))
    a, b = tri[:100_000], tri[100_000:]
    # Half the pairs graze: a corner of the first pushed into the plane of the second.
    graze = rng.random(100_000) < 0.5
    w = rng.random((100_000, 3))
    w /= w.sum(axis=1, keepdims=True)
    on_b = np.einsum("pk,pkc->pc", w, nodes[b])
    nodes = np.concatenate([nodes, on_b[graze]])
    a = a.copy()
    a[graze, 0] = 3000 + np.arange(graze.sum())
    expected = _reference_edges_cross(nodes[a], nodes[b])
    got = _edges_cross([coordinates(nodes, a[:, k]) for k in range(3)],
                       [coordinates(nodes, b[:, k]) for k in range(3)])
    assert np.array_equal(got, expected) and 0 < expected.sum() < len(a)


def test_float32_boxes_hold_their_triangles():
    """The pair filter's boxes are float32: rounded outwards, every triangle
    stays inside its box, and the box is no more than a float32 step wider."""
    from core.intersect import _pair_rows

    rng = np.random.default_rng(7)
    nodes = rng.uniform(-500.0, 1500.0, (3000, 3))
    tri = rng.integers(0, len(nodes), (5000, 3))
    lower, upper = _pair_rows(nodes, tri)
    corners = nodes[tri]  # (T, 3 corners, 3 axes)
    low, high = corners.min(axis=1).T, corners.max(axis=1).T
    assert lower.dtype == np.float32 and upper.dtype == np.float32
    assert np.all(lower <= low) and np.all(upper >= high)
    step = np.spacing(np.float32(2048.0))
    assert np.all(low - lower <= step) and np.all(upper - high <= step)


def test_box_dilation_by_shifts_is_scipys():
    from scipy import ndimage

    from core.intersect import _dilated

    rng = np.random.default_rng(5)
    for shape in [(1, 1, 1), (2, 3, 1), (7, 9, 11), (30, 20, 5)]:
        mask = rng.random(shape) < 0.05
        assert np.array_equal(_dilated(mask), ndimage.binary_dilation(mask, np.ones((3, 3, 3), bool)))


def test_the_compiled_search_reports_its_first_round_seed_block_by_seed_block(monkeypatch, compiled):
    """The progress of the first round goes over all its seeds, in order, and changes no result."""
    from core import crossing_kernel
    from core.intersect import _BALLS_SHARE

    monkeypatch.setenv("URBANVOX_JIT", "1")
    compiled("crossing_kernel")
    monkeypatch.setattr(crossing_kernel, "_SEED_BLOCK", 16)
    old, quads = stacked_grids()
    rng = np.random.default_rng(2)
    moved = rng.random(len(old)) < 0.5
    new = old.copy()
    new[moved] += rng.normal(scale=0.25, size=(moved.sum(), 3))
    seen = []
    reported = undo_crossings(old, new, moved, quads, progress=lambda f, m: seen.append((f, m)))
    quiet = undo_crossings(old, new, moved, quads)
    assert reported[2] == quiet[2] > 0
    assert np.array_equal(reported[0], quiet[0]) and np.array_equal(reported[1], quiet[1])
    fractions = [f for f, _ in seen]
    seeds = np.count_nonzero(touching(moved, quads))  # the first round's: the quads around a moved node
    # The balls first, then every block of seeds.
    assert len(seen) == 1 + -(-seeds // 16) and fractions == sorted(fractions) and fractions[-1] == 1.0
    assert fractions[0] == _BALLS_SHARE
    assert {m for _, m in seen} == {"face crossings"}
