"""The compiled search of the air under cover (core.classify_kernel) against
numpy's (core.classify.covered_air_cells): the same cells and heights, and the
same enclosed air."""
import numpy as np
import pytest

from core import classify
from core.classify import AIR, BUILDING, GROUND


@pytest.fixture
def kernel(compiled):
    return compiled("classify_kernel")


@pytest.mark.parametrize("seed", range(10))
def test_covered_air_is_numpys(with_numpy, kernel, seed):
    """Random grids, flat along any axis, from noise to overhangs over open air."""
    rng = np.random.default_rng(seed)
    shape = tuple(int(v) for v in rng.integers(1, 30, 3))
    labels = rng.choice(np.array([GROUND, BUILDING, AIR], np.uint8), shape, p=[0.1, 0.2, 0.7])
    if seed % 2:
        labels[:, :, -1] = AIR  # the extra empty top row
    if seed % 3 == 0:
        labels[:, :, :] = AIR  # no cover at all
        labels[: shape[0] // 2, :, shape[2] // 2] = BUILDING  # a slab over air
    cells, top = with_numpy(classify.covered_air_cells, labels)
    got_cells, got_top = kernel.covered_air(labels, AIR)
    assert got_cells.dtype == np.int64 and np.array_equal(got_cells, cells)
    assert np.array_equal(got_top, top)
    if seed % 3 == 0 and shape[2] > 1 and shape[0] > 1:
        assert len(cells) > 0


def test_enclosed_air_is_the_same_either_way(with_numpy, kernel):
    """A courtyard closed on every side and a roof over open-sided air."""
    labels = np.full((12, 12, 8), AIR, np.uint8)
    labels[:, :, :2] = GROUND
    labels[2:10, 2:10, 2:6] = BUILDING
    labels[4:8, 4:8, 2:5] = AIR  # closed under the roof at k = 5: enclosed
    labels[0:2, 0:6, 4] = BUILDING  # an eave over air open at the side: reached
    expected = labels.copy()
    turned = with_numpy(classify.enclose_air, expected)
    assert turned == 4 * 4 * 3 and classify.enclose_air(labels) == turned
    assert np.array_equal(labels, expected)


@pytest.mark.parametrize("seed", range(8))
@pytest.mark.parametrize("fill_to_top", [False, True])
def test_first_labels_are_numpys(kernel, seed, fill_to_top):
    """Ground of random heights, building cells below, in and above it,
    repeated, columns with several: the labels before the air front."""
    rng = np.random.default_rng(seed)
    shape = tuple(int(v) for v in rng.integers(1, 25, 2)) + (int(rng.integers(3, 25)),)
    top = rng.integers(0, shape[2] - 1, shape[:2])
    cells = np.column_stack([rng.integers(0, shape[0], 300), rng.integers(0, shape[1], 300),
                             rng.integers(0, shape[2], 300)])
    if seed == 0:
        cells = cells[:0]
    expected = classify._label_columns(shape, top, cells, fill_to_top)
    got = kernel.label_columns(shape, top, cells, fill_to_top, GROUND, BUILDING, AIR)
    assert got.dtype == np.uint8 and np.array_equal(got, expected)
    assert (expected == GROUND).any() and (seed == 0 or (expected == BUILDING).any())
