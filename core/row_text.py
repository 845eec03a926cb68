"""Rows of numbers as text, character for character as printf formats them.

The text mesh formats (gmsh ``.msh`` 4.1 ASCII, OBJ) are millions of lines of
``%d`` and ``%.4f`` fields. Python's ``%`` operator formats each number on
its own (3 s for the 4.5 M nodes of the 1 km synthetic city, 3.5 s for its
9.7 M triangles); here a column's digits are made four at a time for a
block of rows with numpy, laid out in a table of characters and read off
row by row, and the blocks run on all cores. Where numba runs
(:mod:`core.jit`), :mod:`core.row_text_kernel` writes each row's characters
in one pass instead, with the same arithmetic.

The text is exactly the operator's. ``%d`` of an integer is its digits.
``%.Nf`` is the decimal nearest to the double's exact value, ties to even.
``|x| * 10**N`` is the one rounding (``10**N`` is exact), off by at most
half a unit in its last place, so its nearest integer is the decimal's
wherever it lies farther than that from a half; the other values (ties
such as 0.03125 at four decimals, huge ones, NaN and infinities) are
formatted by the operator itself, row by row.
"""
from __future__ import annotations

import re
import sys
from typing import Iterator

import numpy as np

from . import jit
from .parallel import map_ahead, row_blocks

#: The fields the numpy path writes; any other conversion goes to the operator.
_FIELD = re.compile(r"%(?:d|\.(\d+)f)")
#: Rows laid out at a time (a table of a few MB).
_BLOCK = 65536


def format_rows(row_format: str, rows: np.ndarray) -> str:
    """``(row_format + "\\n") * len(rows) % tuple(rows.ravel().tolist())``.

    Parameters
    ----------
    row_format : str
        Fields ``%d`` (integer ``rows``) or ``%.Nf`` (float ``rows``), one
        per column, between literal text. Other formats are handed to the
        ``%`` operator whole.
    rows : ndarray (R, C)

    Examples
    --------
    >>> format_rows("v %.4f %.4f", np.array([[-0.0, 2.5], [0.03125, 1234.56789]]))
    'v -0.0000 2.5000\\nv 0.0312 1234.5679\\n'
    >>> format_rows("%d %d", np.array([[1, -20], [0, 345]]))
    '1 -20\\n0 345\\n'
    """
    return b"".join(encoded_rows(row_format, rows)).decode("ascii")


def encoded_rows(row_format: str, rows: np.ndarray) -> Iterator[bytes]:
    """The text of :func:`format_rows` as ASCII bytes, a block of rows at a
    time, in order: a file is written without the whole text in memory (300
    MB for the 1 km city's triangles), and without a text layer's encoding
    (1.7 s of the 500 MB ``.msh`` of that city)."""
    layout = _layout(row_format, rows)
    blocks = row_blocks(len(rows), _BLOCK)
    if layout is None:
        for block in blocks:
            yield by_operator(row_format, rows[block])
        return
    # Each row's text from its own row, the blocks on the threads ahead of the caller (core.parallel).
    yield from map_ahead(lambda block: _block_text(row_format, layout, rows[block], len(rows)), blocks)


def write_rows(out, row_format: str, rows: np.ndarray) -> None:
    """``np.savetxt(out, rows, fmt=row_format)`` into a binary file: the same
    text (:func:`encoded_rows`), a block of rows at a time."""
    for text in encoded_rows(row_format, rows):
        out.write(text)


def row_texts(row_format: str, rows: np.ndarray) -> np.ndarray:
    """The text of every row, without its newline (an object array of str).

    Examples
    --------
    >>> row_texts("%d: %.1f", np.array([[1.0, 0.25], [2.0, -3.0]])).tolist()
    ['1: 0.2', '2: -3.0']
    """
    text = np.empty(len(rows), dtype=object)
    start = 0
    for block in encoded_rows(row_format, rows):
        lines = block.decode("ascii").split("\n")[:-1]
        text[start:start + len(lines)] = lines
        start += len(lines)
    return text


def encoded_block(row_format: str, rows: np.ndarray, size: int | None = None) -> bytes:
    """The text of :func:`format_rows` as ASCII bytes, made on this thread:
    for a caller that runs blocks of rows on threads itself (a block of
    ``size`` rows in all, to choose the compiled code, :mod:`core.jit`)."""
    layout = _layout(row_format, rows)
    if layout is None:
        return by_operator(row_format, rows)
    return _block_text(row_format, layout, rows, size)


def by_operator(row_format: str, rows: np.ndarray) -> bytes:
    """The ``%`` operator's text of ``rows`` (the reference, and the rows
    the faster paths cannot vouch for), as ASCII bytes.

    Examples
    --------
    >>> by_operator("%.4f %d", np.array([[0.03125, 7.0]]))
    b'0.0312 7\\n'
    """
    return ((row_format + "\n") * len(rows) % tuple(rows.ravel().tolist())).encode("ascii")


def _layout(row_format: str, rows: np.ndarray) -> tuple[list[bytes], list[int | None]] | None:
    """Literal parts and field kinds (``None`` for ``%d``, N for ``%.Nf``),
    or ``None`` where the numpy path does not apply."""
    if rows.ndim != 2 or sys.byteorder != "little":  # the slots are little-endian words
        return None
    literals = [part.encode("ascii") for part in _FIELD.split(row_format)[::2]]
    decimals = [None if m.group(1) is None else int(m.group(1)) for m in _FIELD.finditer(row_format)]
    # NUL marks the unused cells of the table (_laid_out).
    if any(b"%" in part or b"\0" in part for part in literals) or len(decimals) != rows.shape[1]:
        return None
    if np.issubdtype(rows.dtype, np.integer):
        fits = all(d is None for d in decimals) and (rows.dtype.itemsize < 8 or rows.dtype.kind == "i")
    elif np.issubdtype(rows.dtype, np.floating):
        fits = all(d is not None and d <= 15 for d in decimals)
    else:
        fits = False
    return (literals, decimals) if fits else None


def _block_text(row_format: str, layout: tuple[list[bytes], list[int | None]], rows: np.ndarray,
                size: int | None = None) -> bytes:
    """The text of a block of rows (of ``size`` rows in all); rows the numpy
    path cannot vouch for are formatted by the operator, in their place."""
    literals, decimals = layout
    text = jit.run("row_text_kernel", "block_text", row_format, literals, decimals, rows, size=size)
    if text is not None:  # the compiled twin's (core.row_text_kernel): the same bytes
        return text
    fields, exact = [], np.ones(len(rows), dtype=bool)
    for column, places in enumerate(decimals):
        value = rows[:, column]
        if places is None:
            value = value.astype(np.int64, copy=False)
            fits = value != np.iinfo(np.int64).min  # its absolute value overflows
            exact &= fits
            fields.append((value < 0, np.where(fits, np.abs(value), 0), None, 0))
            continue
        with np.errstate(invalid="ignore", over="ignore"):
            scaled = np.abs(value) * 10.0**places
            # The product's error is at most half its last place, below
            # scaled * 2**-53: a margin of twice that from a half.
            fits = (np.isfinite(scaled) & (scaled < 2.0**52)
                    & (np.abs(scaled - np.floor(scaled) - 0.5) > scaled * 2.0**-52))
        exact &= fits
        count = np.rint(np.where(fits, scaled, 0.0)).astype(np.int64)
        whole, fraction = np.divmod(count, 10**places)
        fields.append((np.signbit(value), whole, fraction, places))
    if exact.all():
        return _laid_out(literals, fields)
    # Rare rows the operator formats: the block in runs between them.
    text, start = [], 0
    for row in [*np.flatnonzero(~exact).tolist(), len(rows)]:
        if row > start:
            text.append(_laid_out(literals, [_rows_of(field, slice(start, row)) for field in fields]))
        if row < len(rows):
            text.append(by_operator(row_format, rows[row:row + 1]))
        start = row + 1
    return b"".join(text)


def _rows_of(field: tuple, rows: slice) -> tuple:
    negative, whole, fraction, places = field
    return negative[rows], whole[rows], None if fraction is None else fraction[rows], places


def _laid_out(literals: list[bytes], fields: list[tuple]) -> bytes:
    """The rows' characters in a table of 4-byte slots, NUL where unused,
    read off without the NULs.

    Digits come four at a time, from a table of the 10,000 four-character
    groups ("0000" to "9999", a 4-byte word each); a slot is a column of the
    table viewed as 32-bit words. A number's leading zeros are masked to
    NUL, so are a fraction's cells past its places, the free cells of a
    literal's last slot and the first three of a sign's slot.
    """
    n = len(fields[0][0])
    slots = []  # (n,) uint32 words, left to right
    for k, (negative, whole, fraction, places) in enumerate(fields):
        # The literal before the field, and the sign in the last byte of its last slot.
        text = literals[k] + b"\0" * (-(len(literals[k]) + 1) % 4)
        slots += _constant_slots(text, n)
        slots[-1] |= np.where(negative, np.uint32(ord("-") << 24), np.uint32(0))
        groups = _groups(whole)
        zeros_before = None  # only zero groups so far (None: all rows, before the first group)
        for g, value in enumerate(groups):
            # Leading zeros of the number: those of its first nonzero group
            # (all four of a zero group); the units keep their last digit.
            cut = (_LEADING_ZEROS_CUT_UNITS if g == len(groups) - 1 else _LEADING_ZEROS_CUT).take(value)
            if zeros_before is not None:
                cut[~zeros_before] = 0xFFFFFFFF
            slots.append(_GROUP_TEXT.take(value) & cut)
            if g < len(groups) - 1:
                zeros_before = (value == 0) if zeros_before is None else zeros_before & (value == 0)
        if places:
            slots.append(np.full(n, ord("."), dtype=np.uint32))
            count = -(-places // 4)
            groups = _groups(fraction * 10 ** (4 * count - places), count)  # places digits, then zeros
            words = [_GROUP_TEXT.take(value) for value in groups]
            words[-1] &= _KEEP_FIRST[4 - (4 * count - places)]  # the zeros past the places: NUL
            slots += words
    slots += _constant_slots(literals[-1] + b"\n", n)
    table = np.column_stack(slots).view(np.uint8)
    return table[table != 0].tobytes()


def _groups(value: np.ndarray, count: int | None = None) -> list[np.ndarray]:
    """The four-digit groups (0-9999) of non-negative int64 ``value``, most
    significant first: ``count`` of them, or as many as the largest needs."""
    if count is None:
        largest, count = int(value.max(initial=0)), 1
        while largest >= 10 ** (4 * count):
            count += 1
    # 32-bit division where the values fit (below 10**8): several times faster.
    groups, rest = [], value.astype(np.uint32) if count <= 2 else value
    for _ in range(count - 1):
        high = rest // rest.dtype.type(10000)
        groups.append((rest - high * rest.dtype.type(10000)).astype(np.intp))
        rest = high
    groups.append(rest.astype(np.intp))
    return groups[::-1]


def _constant_slots(text: bytes, n: int) -> list[np.ndarray]:
    """Slots holding ``text``, NUL-padded to whole slots, on every row."""
    text += b"\0" * (-len(text) % 4)
    return [np.full(n, word, dtype=np.uint32) for word in np.frombuffer(text, dtype="<u4").tolist()]


def _text_words() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    # Little-endian words: a group's first character in the lowest byte.
    text = np.frombuffer(np.char.zfill(np.arange(10000).astype("U4"), 4).astype("S4").tobytes(), dtype="<u4")
    keep_first = np.array([0, 0xFF, 0xFFFF, 0xFFFFFF, 0xFFFFFFFF], dtype=np.uint32)  # the first k bytes
    leading = 4 - np.char.str_len(np.arange(10000).astype("U4"))  # 0 -> "0": three
    cut = ~keep_first[leading]
    cut_zero_group = cut.copy()
    cut_zero_group[0] = 0  # a zero group before the number's first digit: all four
    return text.astype(np.uint32), cut_zero_group, cut, keep_first


#: "0000".."9999" as 4-byte words; masks that cut a group's leading zeros
#: (all four of 0, or three where the group holds the units); masks keeping
#: a word's first k bytes.
_GROUP_TEXT, _LEADING_ZEROS_CUT, _LEADING_ZEROS_CUT_UNITS, _KEEP_FIRST = _text_words()
