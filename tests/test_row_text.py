"""core.row_text: the text of rows of numbers, against Python's % operator."""
import numpy as np
import pytest

from core import row_text
from core.row_text import encoded_rows, format_rows


def by_operator(row_format, rows):
    return (row_format + "\n") * len(rows) % tuple(rows.ravel().tolist())


def awkward_floats(rng):
    """Values of every magnitude, exact ties, near ties, signed zeros, non-finite ones."""
    return np.concatenate([
        rng.normal(0, 1, 20_000) * 10.0 ** rng.integers(-8, 12, 20_000),
        rng.integers(-10**6, 10**6, 20_000) / 32.0,  # ties at 4 decimals and fewer (k/32)
        rng.integers(-10**9, 10**9, 20_000) * 0.5 + 0.00005,  # near ties: 0.00005 is not a double
        2.6e6 + rng.random(20_000) * 1000,  # projected coordinates
        [0.0, -0.0, 1e-5, -1e-5, 0.00015, 4.99995, 99999.99995, 1e15, 2.0**52, -1e17, 1e300,
         np.nan, np.inf, -np.inf],
    ])


@pytest.mark.parametrize("places", [0, 1, 3, 4, 6, 9])
def test_fixed_point_text_is_the_operators(places):
    values = awkward_floats(np.random.default_rng(places))
    rows = np.column_stack([values, values[::-1]])
    row_format = f"v %.{places}f,%.{places}f;"
    assert format_rows(row_format, rows) == by_operator(row_format, rows)


@pytest.mark.parametrize("dtype", [np.int64, np.int32, np.int16, np.uint32, np.uint8])
def test_integer_text_is_the_operators(dtype):
    rng = np.random.default_rng(1)
    info = np.iinfo(dtype)
    # The digit counts' edges that the type holds (numpy 2 refuses to wrap the others).
    edges = [v for v in (0, 1, 9, 10, 99, 100, 9999, 10000) if info.min <= v <= info.max] + [info.min, info.max]
    values = np.concatenate([rng.integers(info.min, info.max, 20_000, dtype=dtype, endpoint=True),
                             np.array(edges, dtype=dtype)])
    rows = np.column_stack([values, values[::-1], np.zeros_like(values)])
    assert format_rows("%d  %d %d", rows) == by_operator("%d  %d %d", rows)
    assert format_rows("f %d %d %d", rows) == by_operator("f %d %d %d", rows)


def test_rows_past_the_fast_path_keep_their_place(monkeypatch):
    # Small blocks: several blocks per batch of threads, and rows the operator
    # formats (ties, NaN) at the start, middle and end of blocks.
    monkeypatch.setattr(row_text, "_BLOCK", 7)
    values = np.arange(100) * 0.37
    values[[0, 6, 7, 50, 99]] = [0.03125, np.nan, 0.09375, np.inf, 0.15625]
    rows = np.column_stack([values, -values])
    assert format_rows("%.4f %.4f", rows) == by_operator("%.4f %.4f", rows)
    blocks = list(encoded_rows("%.4f %.4f", rows))
    assert len(blocks) == 15 and all(isinstance(block, bytes) for block in blocks)


def test_other_formats_go_to_the_operator():
    floats = np.array([[1.5, -2.25], [3.0, 1e-7]])
    for row_format, rows in (("%.3e %.2e", floats), ("%d%% %d", np.array([[1, 2]])),
                             ("%d %d", floats), ("%.2f %.2f", np.array([[1, 2]])), ("%5d %d", np.array([[1, 2]])),
                             ("%d\0%d", np.array([[1, 2]]))):
        assert format_rows(row_format, rows) == by_operator(row_format, rows)
    assert format_rows("%d", np.zeros((0, 1), dtype=int)) == ""
    big = np.array([[2**64 - 1, 0]], dtype=np.uint64)  # beyond int64
    assert format_rows("%d %d", big) == by_operator("%d %d", big)
