"""The compiled chords of the ground (core.ground_kernel) against numpy's (core.ground)."""
import numpy as np
import pytest

from core import ground


def random_gaps(seed: int, shape: tuple[int, int], share: float) -> tuple[np.ndarray, np.ndarray]:
    """Levels and the columns observed: a tilted, bumpy ground with rectangular
    roofs over a share of it (gaps of many sizes, some open to the grid's
    edges) and scattered missing columns."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.arange(shape[0]), np.arange(shape[1]), indexing="ij")
    z = 3 + 0.1 * x - 0.05 * y + rng.normal(scale=0.2, size=shape)
    observed = rng.random(shape) > 0.05
    for _ in range(int(share * shape[0] * shape[1] / 30)):
        i, j = rng.integers(0, shape[0]), rng.integers(0, shape[1])
        observed[i:i + rng.integers(1, 12), j:j + rng.integers(1, 12)] = False
    return np.where(observed, z, np.nan), observed


@pytest.mark.parametrize("threads", ["1", "3"])
@pytest.mark.parametrize("shape", [(1, 40), (40, 1), (2, 3), (57, 43), (300, 200)])
def test_chords_are_numpys_to_the_last_bit(compiled, with_numpy, monkeypatch, threads, shape):
    """The filled levels with the kernel and with numpy, bit for bit, on one
    thread and on three (a direction's two walks on two, the sums in
    blocks); and the steps of every walk against steps_to_observed's."""
    monkeypatch.setenv("URBANVOX_THREADS", threads)
    kernel = compiled("ground_kernel")
    z, observed = random_gaps(shape[0] * shape[1], shape, 0.6)
    observed.flat[0] = True  # at least one observed column
    expected = with_numpy(ground._fill_missing, z, observed)
    got = ground._fill_missing(z, observed)
    assert not np.isnan(expected).any() and np.array_equal(got, expected)

    missing = np.flatnonzero(~observed)
    longest, left = 0, False
    for di, dj in ground.CHORD_DIRECTIONS:
        behind, ahead = kernel.walk_steps(observed, di, dj)
        assert np.array_equal(behind, ground.steps_to_observed(observed, di, dj).ravel().take(missing))
        back = ground.steps_to_observed(observed[::-1, ::-1], di, dj)[::-1, ::-1]
        assert np.array_equal(ahead, back.ravel().take(missing))
        longest, left = max(longest, int(behind.max(initial=0))), left or bool((ahead == -1).any())
    if min(shape) > 40:  # long chords, and lines that leave the grid, both met
        assert longest > 10 and left


def test_a_tilted_plane_is_filled_exactly_through_the_kernel(compiled):
    compiled("ground_kernel")
    x, y = np.meshgrid(np.arange(120.0), np.arange(90.0), indexing="ij")
    plane = 2 + 0.5 * x - 0.25 * y
    gap = (x > 10) & (x < 70) & (y > 5) & (y < 60)
    filled = ground._fill_missing(np.where(gap, np.nan, plane), ~gap)
    np.testing.assert_allclose(filled, plane, rtol=0, atol=1e-9)


def test_directions_the_walks_cannot_take_are_refused(compiled):
    kernel = compiled("ground_kernel")
    observed = np.ones((3, 3), bool)
    for di, dj in ((0, -1), (3, 1), (-1, 0), (0, 0)):
        with pytest.raises(ValueError, match="di 0 to 2"):
            kernel.walk_steps(observed, di, dj)
