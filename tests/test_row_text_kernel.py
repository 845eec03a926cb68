"""The compiled text of rows (core.row_text_kernel) against Python's %
operator, with the rows numpy's twin (core.row_text) leaves to it."""
import numpy as np
import pytest

from core import row_text
from tests.test_row_text import awkward_floats, by_operator


@pytest.fixture
def kernel(compiled):
    return compiled("row_text_kernel")


def _text(kernel, row_format, rows):
    literals, decimals = row_text._layout(row_format, rows)
    return kernel.block_text(row_format, literals, decimals, rows)


@pytest.mark.parametrize("places", [0, 1, 3, 4, 6, 9])
def test_fixed_point_text_is_the_operators(kernel, places):
    """Values of every magnitude, ties, signed zeros and non-finite ones, in
    blocks of 40 rows and in one."""
    values = awkward_floats(np.random.default_rng(places))
    rows = np.column_stack([values, values[::-1]])
    row_format = f"v %.{places}f,%.{places}f;"
    for start in range(0, 4000, 40):
        block = rows[start:start + 40]
        assert _text(kernel, row_format, block) == by_operator(row_format, block).encode("ascii")
    assert _text(kernel, row_format, rows) == by_operator(row_format, rows).encode("ascii")


@pytest.mark.parametrize("dtype", [np.int64, np.int32, np.int16, np.uint32, np.uint8])
def test_integer_text_is_the_operators(kernel, dtype):
    rng = np.random.default_rng(1)
    info = np.iinfo(dtype)
    edges = [v for v in (0, 1, 9, 10, 99, 100, 9999, 10000) if info.min <= v <= info.max] + [info.min, info.max]
    values = np.concatenate([rng.integers(info.min, info.max, 20_000, dtype=dtype, endpoint=True),
                             np.array(edges, dtype=dtype)])
    rows = np.column_stack([values, values[::-1], np.zeros_like(values)])  # the smallest int64: the operator's
    assert _text(kernel, "f %d %d  %d", rows) == by_operator("f %d %d  %d", rows).encode("ascii")


def test_signs_of_zeros_and_of_values_rounded_to_zero(kernel):
    rows = np.array([[-0.0, 0.0], [-1e-5, 1e-5], [-0.00004, 12.34567]])
    assert _text(kernel, "%.4f %.4f", rows) == by_operator("%.4f %.4f", rows).encode("ascii") \
        == b"-0.0000 0.0000\n-0.0000 0.0000\n-0.0000 12.3457\n"


def test_float32_rows_are_left_to_numpy(kernel):
    """numpy's product of float32 rows is in float32: not the kernel's."""
    assert kernel.block_text("%.4f", [b"", b""], [4], np.array([[0.1]], dtype=np.float32)) is None


@pytest.mark.parametrize("switch", ["0", "always"])
def test_files_text_is_the_operators_both_ways(switch, monkeypatch, compiled):
    """format_rows in small blocks on the threads, compiled or numpy."""
    monkeypatch.setenv("URBANVOX_JIT", switch)
    if switch == "always":
        compiled("row_text_kernel")
    monkeypatch.setattr(row_text, "_BLOCK", 50)
    values = awkward_floats(np.random.default_rng(7))
    rows = np.column_stack([values, -values, values[::-1]])
    assert row_text.format_rows("%.4f %.4f %.4f", rows) == by_operator("%.4f %.4f %.4f", rows)
    integers = np.random.default_rng(8).integers(-10**12, 10**12, (30_000, 4))
    assert row_text.format_rows("%d %d %d %d", integers) == by_operator("%d %d %d %d", integers)
