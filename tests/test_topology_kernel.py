"""The compiled selections (core.topology_kernel) against numpy's (core.topology)."""
import numpy as np
import pytest

from core import topology


@pytest.fixture
def kernel(compiled):
    return compiled("topology_kernel")


@pytest.mark.parametrize("dtype", [np.int64, np.int32])
@pytest.mark.parametrize("corners", [3, 4])
def test_touching_is_numpys(monkeypatch, kernel, dtype, corners):
    rng = np.random.default_rng(corners)
    marked = rng.random(50_000) < 0.05
    faces = rng.integers(0, len(marked), size=(200_000, corners)).astype(dtype)
    with monkeypatch.context() as patch:
        patch.setenv("URBANVOX_JIT", "0")
        expected = topology.touching(marked, faces)
    got = kernel.touching(marked, faces)
    assert 0 < expected.sum() < len(faces) and np.array_equal(got, expected)
    # Strided columns (a view of a wider table) give the same answer.
    wide = np.column_stack([faces, faces[:, :1]])
    assert np.array_equal(kernel.touching(marked, wide[:, :corners]), expected)


def test_changed_rows_is_numpys_with_nan_and_signed_zeros(monkeypatch, kernel):
    rng = np.random.default_rng(7)
    old = rng.normal(size=(300_000, 3))
    new = old.copy()
    moved = rng.random(len(old)) < 0.3
    new[moved, rng.integers(0, 3, moved.sum())] += 1e-12
    new[:100] = -0.0
    old[:100] = 0.0  # equal: -0.0 == 0.0
    new[100:200, 1] = np.nan  # NaN differs from everything, itself included
    old[100:150, 1] = np.nan
    with monkeypatch.context() as patch:
        patch.setenv("URBANVOX_JIT", "0")
        expected = topology.changed_rows(new, old)
    got = kernel.changed_rows(new, old)
    assert not expected[:100].any() and expected[100:200].all()
    assert np.array_equal(got, expected)


def test_large_selections_run_compiled(monkeypatch, kernel):
    calls = []
    monkeypatch.setattr(kernel, "touching", lambda *args, real=kernel.touching: calls.append(1) or real(*args))
    marked = np.zeros(10, dtype=bool)
    marked[3] = True
    faces = np.tile(np.array([[0, 1, 2, 3], [4, 5, 6, 7]]), (topology._KERNEL_ROWS, 1))
    hit = topology.touching(marked, faces)
    assert calls and hit[0::2].all() and not hit[1::2].any()


@pytest.mark.parametrize("n_keys", [1, 300, 1 << 16, (1 << 16) + 1, 10**6])
def test_stable_order_is_numpys_stable_argsort(n_keys):
    """Keys of 16 bits (numpy's radix sort) and wider ones: the order of a
    stable argsort of the keys as given, ties in their first order."""
    rng = np.random.default_rng(n_keys)
    key = rng.integers(0, n_keys, 200_000)
    key[:10] = n_keys - 1  # the largest key, which 16 bits must hold
    order = topology.stable_order(key, n_keys)
    assert np.array_equal(order, np.argsort(key, kind="stable"))
