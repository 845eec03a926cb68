"""The compiled quad quality (core.quality_kernel) against numpy's
(core.quality): the same splits, qualities and normals to the last bit."""
import numpy as np
import pytest

from core import quality


@pytest.fixture
def kernel(compiled):
    return compiled("quality_kernel")


def numpy_split_quality(monkeypatch, nodes, quads, normals=True):
    with monkeypatch.context() as patch:
        patch.setenv("URBANVOX_JIT", "0")
        return quality._split_quality(nodes, quads, normals=normals)


def awkward_nodes(rng):
    """Nodes of shaken lattice quads, and of flat, twisted, degenerate and NaN ones."""
    lattice = rng.normal(scale=0.2, size=(20_000, 3)) + rng.integers(0, 30, size=(20_000, 3))
    coarse = rng.integers(0, 3, size=(2_000, 3)).astype(float)
    coarse[:20, 0] = np.nan
    coarse[20:40] = coarse[40:60]  # coincident corners
    return lattice, coarse


@pytest.mark.parametrize("dtype", [np.int64, np.int32])
def test_same_splits_qualities_and_normals_as_numpy(monkeypatch, kernel, dtype):
    rng = np.random.default_rng(3)
    for nodes in awkward_nodes(rng):
        quads = rng.integers(0, len(nodes), size=(60_000, 4)).astype(dtype)
        expected = numpy_split_quality(monkeypatch, nodes, quads)
        got = kernel.split_quality(nodes, quads)
        for name, e, g in zip(("use_second", "quality", "normal"), expected, got):
            assert g.dtype == e.dtype and g.shape == e.shape, name
            assert np.array_equal(g, e, equal_nan=e.dtype != bool), name
        assert np.isnan(got[1]).any() == np.isnan(expected[1]).any()
        without = kernel.split_quality(nodes, quads, normals=False)
        assert without[2] is None and np.array_equal(without[1], got[1], equal_nan=True)


@pytest.mark.parametrize("threads", ["1", "3"])
def test_qualities_written_into_their_rows_are_numpys(monkeypatch, kernel, threads):
    """split_quality_into against numpy's rows of the same quads (awkward
    ones, NaN included), written into tables that keep their other rows."""
    monkeypatch.setenv("URBANVOX_THREADS", threads)
    rng = np.random.default_rng(6)
    for nodes in awkward_nodes(rng):
        quads = rng.integers(0, len(nodes), size=(60_000, 4)).astype(np.int32)
        rows = np.flatnonzero(rng.random(len(quads)) < 0.7)
        expected = numpy_split_quality(monkeypatch, nodes, quads)
        quality_of, normal = np.full(len(quads), -7.0), np.full((len(quads), 3), -7.0)
        assert kernel.split_quality_into(nodes, quads, rows, quality_of, normal) == len(rows)
        assert np.array_equal(quality_of[rows], expected[1][rows], equal_nan=True)
        assert np.array_equal(normal[rows], expected[2][rows], equal_nan=True)
        others = np.setdiff1d(np.arange(len(quads)), rows)
        assert (quality_of[others] == -7).all() and (normal[others] == -7).all()


def test_the_quality_control_uses_the_kernel_with_the_same_moves(monkeypatch, kernel):
    # accept_moves through the kernel (loaded: it runs for any size) and through numpy.
    rng = np.random.default_rng(4)
    n = 60
    x, y = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float), indexing="ij")
    nodes = np.column_stack([x.ravel(), y.ravel(), np.zeros(n * n)])
    corner = (np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]).ravel()
    quads = np.column_stack([corner, corner + n, corner + n + 1, corner + 1])
    proposal = nodes + rng.normal(scale=0.35, size=nodes.shape)
    calls = []
    monkeypatch.setattr(kernel, "split_quality",
                        lambda *args, real=kernel.split_quality: calls.append(1) or real(*args))
    got = quality.accept_moves(nodes, proposal, quads, 0.3)
    assert calls
    with monkeypatch.context() as patch:
        patch.setenv("URBANVOX_JIT", "0")
        expected = quality.accept_moves(nodes, proposal, quads, 0.3)
    assert 0 < expected[1].sum() < len(nodes)  # some moves kept, some undone
    assert np.array_equal(got[0], expected[0]) and np.array_equal(got[1], expected[1])
