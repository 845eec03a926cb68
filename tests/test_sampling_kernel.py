"""The compiled cells of sample points (core.sampling_kernel) against numpy's (core.sampling)."""
import numpy as np
import pytest

from core.sampling import sample_thinned


def _city_like(seed: int, count: int) -> np.ndarray:
    """Triangles of many sizes at projected coordinates, some flat (roofs), some vertical
    (walls), some tiny: runs of one cell and long runs, cells shared between triangles."""
    rng = np.random.default_rng(seed)
    base = np.array([2_600_000.0, 1_200_000.0, 400.0]) + rng.random((count, 1, 3)) * [200, 200, 20]
    size = rng.choice([0.05, 1.0, 8.0, 30.0], size=(count, 1, 1))
    corners = base + rng.random((count, 3, 3)) * size
    corners[: count // 3, :, 2] = corners[: count // 3, :1, 2]  # flat
    corners[count // 3: 2 * count // 3, :, 1] = corners[count // 3: 2 * count // 3, :1, 1]  # vertical
    return corners


@pytest.mark.parametrize("seed, count, cell", [(0, 50, 0.5 / 3), (1, 400, 1 / 3), (2, 3, 0.1), (3, 200, 2.0)])
def test_thinned_samples_are_numpys_to_the_last_bit(compiled, with_numpy, seed, count, cell):
    """The mean point of every cell, with the kernel and with numpy, bit for bit, chunked small
    (cells split between chunks) and whole."""
    compiled("sampling_kernel")
    corners = _city_like(seed, count)
    for chunk in (997, 5_000_000):
        ours = sample_thinned(corners, 0.3 * cell, cell, chunk_points=chunk)
        numpys = with_numpy(sample_thinned, corners, 0.3 * cell, cell, None, chunk)
        assert len(ours) > 0 and ours.tobytes() == numpys.tobytes()


def test_runs_and_sums_of_a_few_points(compiled):
    """Runs across cells and back: the same cell twice is two runs summed into one cell."""
    kernel = compiled("sampling_kernel")
    points = np.array([[0.1, 0.1, 0.1], [0.2, 0.1, 0.1], [1.5, 0.1, 0.1], [0.3, 0.3, 0.3], [0.2, 2.5, 0.0]])
    keys, starts = kernel.cell_runs(points, 1.0, np.zeros(3, np.int64))
    assert keys.tolist() == [0, 1, 0, 2 << 21] and starts.tolist() == [0, 2, 3, 4]
    sums, counts = kernel.run_sums(points, starts, np.array([0, 1, 0, 2]), 3)
    assert counts.tolist() == [3.0, 1.0, 1.0]
    assert sums[0].tolist() == [(0.1 + 0.2) + 0.3, (0.1 + 0.1) + 0.3, (0.1 + 0.1) + 0.3]
