"""Compiled rows of numbers as text (numba, :mod:`core.jit`).

:mod:`core.row_text` writes the ``%d`` and ``%.Nf`` fields of the text mesh
formats with numpy: a column's digits four at a time, laid out in a table
of characters and read off without its blanks. That is a dozen passes over
a block's columns; here each row's characters are written once, in order,
into the block's text. The arithmetic is the numpy twin's (the same
product, test and rounding of every value). On the 1 km synthetic city's
gmsh text (4.8 M nodes, 9.7 M triangles, 450 MB of rows), on one thread:
the nodes 0.63-0.86 s with numpy, 0.47-0.49 s with this; the triangles
1.17-1.25 s and 0.59-0.73 s.

A row with a value the twin hands to the ``%`` operator (a tie at the
places asked for, a huge value, NaN) is left out, and the operator's text
of it put in its place.
"""
from __future__ import annotations

import math

import numpy as np

from .neighbours_kernel import compiled
from .row_text import by_operator

#: ``2**52`` and ``2**-52``, as :func:`core.row_text._block_text` has them.
_LARGEST = 4503599627370496.0
_EPSILON = 2.220446049250313e-16
#: "00".."99", and the powers of ten an unsigned 64-bit integer holds.
_PAIRS = np.frombuffer(b"".join(b"%02d" % i for i in range(100)), dtype=np.uint8)
_POWERS = np.array([10**i for i in range(20)], dtype=np.uint64)


def block_text(row_format: str, literals: list[bytes], decimals: list[int | None], rows: np.ndarray) -> bytes | None:
    """The text of ``rows`` as :func:`core.row_text.format_rows` makes it:
    a row with a value the twin leaves to the ``%`` operator (a tie at the
    places asked for, a huge value, NaN) is the operator's, in its place.

    Parameters
    ----------
    row_format : str
        The fields ``%d`` or ``%.Nf`` between the literals.
    literals : list of bytes
        The text before each field and after the last (``len(decimals) + 1``).
    decimals : list of int or None
        Per column: None for ``%d`` (integer ``rows``), N for ``%.Nf`` (float64 ``rows``).
    rows : ndarray (R, len(decimals))
        Integers, or float64 (other floats: None, the twin's).

    Examples
    --------
    >>> block_text("v %.4f %.4f", [b"v ", b" ", b""], [4, 4], np.array([[-0.0, 2.5], [0.5, 1234.56789]]))
    b'v -0.0000 2.5000\\nv 0.5000 1234.5679\\n'
    >>> block_text("%d %d", [b"", b" ", b""], [None, None], np.array([[1, -20], [0, 345]]))
    b'1 -20\\n0 345\\n'
    >>> block_text("%.4f", [b"", b""], [4], np.array([[0.5], [0.03125], [np.nan]]))  # a tie, NaN: the operator's
    b'0.5000\\n0.0312\\nnan\\n'
    """
    if rows.dtype.kind == "f" and rows.dtype != np.float64:
        return None  # the twin's product is then in that precision
    text = np.frombuffer(b"".join(literals) + b"\n", dtype=np.uint8)
    start = np.cumsum([0] + [len(part) for part in literals[:-1]] + [len(literals[-1]) + 1])
    places = np.array([-1 if p is None else p for p in decimals], dtype=np.int64)
    if places[0] < 0:  # every field %d (core.row_text._layout)
        integers, decimal = np.ascontiguousarray(rows, dtype=np.int64), np.zeros((1, 1))
    else:
        integers, decimal = np.zeros((1, 1), dtype=np.int64), np.ascontiguousarray(rows)
    out, left, left_at = _rows_text(integers, decimal, places, 10.0 ** np.maximum(places, 0), text, start)
    if not len(left):
        return out.tobytes()
    # The operator's text of the rows left, in their places.
    parts, start_at = [], 0
    for row, at in zip(left.tolist(), left_at.tolist()):
        parts += [out[start_at:at].tobytes(), by_operator(row_format, rows[row:row + 1])]
        start_at = at
    parts.append(out[start_at:].tobytes())
    return b"".join(parts)


def warm_up() -> int:
    """Compile for the rows the writers pass (the docstring's)."""
    assert block_text("%d %d", [b"", b" ", b""], [None, None], np.array([[1, -20]])) == b"1 -20\n"
    assert block_text("%.4f", [b"", b""], [4], np.array([[-0.5]])) == b"-0.5000\n"
    return 1


@compiled
def _rows_text(integers, decimal, places, scales, text, start):
    """:func:`block_text` of the rows of ``integers`` (every ``places`` -1)
    or of ``decimal``: the text of the rows but those left to the operator,
    those rows, and where each one's text goes. One function, no calls: a
    call that passes the arrays costs their reference counts, more than a
    number's digits."""
    is_integer = places[0] < 0
    n, columns = integers.shape if is_integer else decimal.shape
    width = start[-1]
    tens = np.ones(columns, np.uint64)
    for c in range(columns):
        width += 22 + max(places[c], 0)  # sign, 20 digits, point
        for _ in range(places[c]):
            tens[c] *= np.uint64(10)
    out = np.empty(n * width, np.uint8)
    left = np.empty(n, np.int64)  # the rows left to the operator, and where their text goes
    left_at = np.empty(n, np.int64)
    n_left = 0
    hundred, ten, two = np.uint64(100), np.uint64(10), np.uint64(2)
    at = 0
    for r in range(n):
        row_at = at
        for c in range(columns + 1):
            for i in range(start[c], start[c + 1]):  # the literal before the field (after the last: and "\n")
                out[at] = text[i]
                at += 1
            if c == columns:
                break
            if is_integer:
                value = integers[r, c]
                negative = value < 0
                if negative and value == -value:  # the smallest int64: its absolute value overflows
                    at = -1
                    break
                whole = np.uint64(-value) if negative else np.uint64(value)
                fraction = np.uint64(0)
            else:
                x = decimal[r, c]
                scaled = abs(x) * scales[c]
                if not (np.isfinite(scaled) and scaled < _LARGEST
                        and abs(scaled - np.floor(scaled) - 0.5) > scaled * _EPSILON):
                    at = -1
                    break
                count = np.uint64(np.rint(scaled))
                negative = math.copysign(1.0, x) < 0.0  # "-" also of -0.0, as printf has it
                whole = count // tens[c]
                fraction = count - whole * tens[c]
            if negative:
                out[at] = 45
                at += 1
            # The whole part's digits without leading zeros, then the point
            # and the fraction's zero-padded: two digits at a time from a
            # table, in unsigned arithmetic (a division by a constant is then
            # a product, and nothing goes through a float).
            for part in range(2):
                if part == 0:
                    value_digits, digits = whole, 1
                    while digits < 20 and whole >= _POWERS[digits]:
                        digits += 1
                elif places[c] > 0:
                    out[at] = 46
                    at += 1
                    value_digits, digits = fraction, places[c]
                else:
                    break
                end = at + digits
                while end - at >= 2:
                    high = value_digits // hundred
                    pair = two * (value_digits - high * hundred)
                    out[end - 2] = _PAIRS[pair]
                    out[end - 1] = _PAIRS[pair + np.uint64(1)]
                    value_digits = high
                    end -= 2
                if end > at:
                    out[at] = np.uint8(value_digits % ten) + np.uint8(48)
                at += digits
        if at < 0:
            at = row_at
            left[n_left] = r
            left_at[n_left] = at
            n_left += 1
    return out[:at], left[:n_left], left_at[:n_left]
