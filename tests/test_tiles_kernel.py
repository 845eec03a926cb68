"""The compiled passes of the tiled run (core.tiles_kernel) against numpy's (core.tiles, core.tile_merge)."""
import numpy as np
import pytest

from core import tile_merge, tiles


@pytest.fixture
def kernel(compiled):
    return compiled("tiles_kernel")


def _copies(seed: int, pieces: int = 6, ranks: int = 12):
    """Copy keys as the merge makes them: per piece, sorted lattice keys
    (overlapping between pieces) times ``ranks`` plus a rank below it."""
    rng = np.random.default_rng(seed)
    keys = []
    for rank in range(pieces):
        lattice = np.unique(rng.integers(0, 30_000, size=20_000))
        keys.append(lattice * ranks + np.where(rng.random(len(lattice)) < 0.5, rank, rank + pieces))
    copy_key = np.concatenate(keys).astype(np.int64)
    starts = np.cumsum([0] + [len(k) for k in keys])
    return copy_key, np.argsort(copy_key, kind="stable"), ranks, starts


def _without_kernels(monkeypatch, func, *args):
    with monkeypatch.context() as patch:
        patch.setenv("URBANVOX_JIT", "0")
        return func(*args)


def test_node_numbers_are_numpys(monkeypatch, kernel):
    copy_key, by_rank, ranks, _ = _copies(1)
    chosen, node_of = _without_kernels(monkeypatch, tile_merge.number_nodes, copy_key, by_rank, ranks)
    got_chosen, got_node_of = kernel.number_nodes(copy_key, by_rank, ranks)
    assert np.array_equal(got_chosen, chosen) and np.array_equal(got_node_of, node_of)
    # What the numbers mean: one node per distinct lattice key, in key order,
    # each copy on its key's node, the chosen copy the lowest-ranked one.
    lattice = copy_key // ranks
    distinct = np.unique(lattice)
    assert len(chosen) == len(distinct) < len(copy_key)
    assert np.array_equal(distinct[node_of], lattice)
    best = np.full(len(distinct), np.iinfo(np.int64).max)
    np.minimum.at(best, node_of, copy_key % ranks)
    assert np.array_equal(copy_key[chosen] % ranks, best)


def test_placed_nodes_and_faces_are_numpys(monkeypatch, kernel):
    copy_key, by_rank, ranks, starts = _copies(2)
    chosen, node_of = tile_merge.number_nodes(copy_key, by_rank, ranks)
    h = 0.37
    outputs = []
    for place in (_without_kernels, None):
        rng = np.random.default_rng(3)  # the same pieces for both
        nodes = np.full((len(chosen), 3), np.nan)
        final = np.full((len(chosen), 3), np.nan)
        quads_out = np.full(((len(starts) - 1) * 5000, 4), -9, dtype=np.int64)
        regions_out = np.full((len(quads_out), 2), -9, dtype=np.int32)
        for rank in range(len(starts) - 1):
            copies = slice(starts[rank], starts[rank + 1])
            n = copies.stop - copies.start
            keys = rng.integers(0, 2000, size=(n, 3)).astype(np.int32)
            moved = keys * h + rng.normal(scale=0.1, size=(n, 3))
            quads = rng.integers(0, n, size=(5000, 4)).astype(np.int32)
            regions = rng.integers(-3, 40, size=(5000, 2)).astype(np.int32)
            renumber = np.concatenate([[0], rng.permutation(39) + 100]).astype(np.int32)
            rows = slice(rank * 5000, (rank + 1) * 5000)
            node_args = (nodes, final, node_of[copies], chosen, copies.start, keys, moved, h)
            face_args = (quads_out[rows], regions_out[rows], node_of[copies], quads, regions, renumber)
            if place is None:
                kernel.place_nodes(*node_args)
                kernel.place_faces(*face_args)
            else:
                place(monkeypatch, tile_merge.place_nodes, *node_args)
                place(monkeypatch, tile_merge.place_faces, *face_args)
            if rank == 0:  # the first piece's chosen copies, checked by hand
                mine = np.flatnonzero(chosen[node_of[copies]] == np.arange(copies.start, copies.stop))
                assert 0 < len(mine) < n
                assert np.array_equal(nodes[node_of[mine]], keys[mine] * h)
                assert np.array_equal(regions_out[rows][regions > 0], renumber[regions[regions > 0]])
        outputs.append((nodes, final, quads_out, regions_out))
    # Every node is placed once, by its chosen copy's piece.
    assert not np.isnan(outputs[0][0]).any() and not np.isnan(outputs[0][1]).any()
    assert (outputs[0][2] >= 0).all()
    for expected, got in zip(*outputs):
        assert np.array_equal(got, expected)


@pytest.mark.parametrize("last", [False, True])  # a core inside the domain, and one on its far sides
def test_owned_faces_are_numpys(monkeypatch, kernel, last):
    rng = np.random.default_rng(5)
    nx, ny = 60, 50
    core = (20, 10, 60, 50) if last else (20, 10, 40, 30)
    # Lattice quads of a window around the core: each face's corners a unit
    # square in a random plane, so centres fall on both sides of every edge.
    n_faces = 40_000
    low = rng.integers(0, [nx, ny, 20], size=(n_faces, 3))
    axis = rng.integers(0, 3, n_faces)
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]])
    corners = np.repeat(low[:, None, :], 4, axis=1)
    for a in range(3):
        rows = axis == a
        in_plane = [b for b in range(3) if b != a]
        corners[np.ix_(rows, [0, 1, 2, 3], in_plane)] += square
    keys, quads = np.unique(corners.reshape(-1, 3), axis=0, return_inverse=True)
    quads = quads.reshape(-1, 4).astype(np.int64)
    regions = rng.integers(-2, 30, size=(n_faces, 2)).astype(np.int32)
    renumber = np.where(rng.random(30) < 0.5, rng.integers(1, 9, 30), 0).astype(np.int32)
    renumber[0] = 0
    keys = keys.astype(np.int32)
    with monkeypatch.context() as patch:
        patch.setenv("URBANVOX_JIT", "0")
        keep, keep_block = tiles.owned_faces(keys, quads, regions, renumber, core, (nx, ny))
    got_keep, got_block = kernel.owned_faces(keys, quads, regions, renumber, core, (nx, ny))
    ground_or_air = (regions <= 0).all(axis=1)
    assert keep_block.any() and (keep & ground_or_air).any() and (~keep & ground_or_air).any()
    assert np.array_equal(got_keep, keep) and np.array_equal(got_block, keep_block)
