"""Compiled allocator of numpy's large arrays (numba ``cfunc``s for :mod:`core.array_heap`).

numpy calls these four functions, through the handler :mod:`core.array_heap`
sets (NEP 49), for the data of every array made on a thread that uses it.
Blocks of :data:`LARGE` bytes or more come from one region of address space
reserved once: the smallest free range that holds a block, freed ranges
merged with their neighbours, the region's pages kept until :func:`return_free_pages` gives
them back. Smaller blocks come from glibc's ``malloc``. Every block starts
with a header of :data:`HEADER` bytes that says which it is and, for the
region's, its size.

The state is one table of unsigned 64-bit words (:func:`new_state`); numpy
calls the functions with the GIL held, as it does its own allocator, whose
cache of small blocks is not thread-safe either, so the table needs no lock.
"""
from __future__ import annotations

import numba
import numpy as np
from numba import carray, types
from numba.extending import intrinsic

from .neighbours_kernel import compiled

#: Bytes before every block's data: its kind, and for the region's blocks its size.
HEADER = 64
#: Arrays of this many bytes or more come from the region.
LARGE = 1 << 20
#: The region's blocks are whole pages.
PAGE = 4096
#: Free ranges the table holds (more are handed back to the system and their space left unused).
RANGES = 4096
#: The table's words: the region's address and size, the top of the part used,
#: the number of free ranges, the highest top reached; then (offset, size) pairs.
BASE, SIZE, TOP, COUNT, HIGH, FIRST = 0, 1, 2, 3, 4, 8

# The C library's functions for the compiled code, by name: linked when the
# cached code loads, so the code can be cached (ctypes pointers cannot).
_malloc = types.ExternalFunction("malloc", types.uintp(types.uintp))
_calloc = types.ExternalFunction("calloc", types.uintp(types.uintp, types.uintp))
_realloc = types.ExternalFunction("realloc", types.uintp(types.uintp, types.uintp))
_free = types.ExternalFunction("free", types.void(types.uintp))
_usable_size = types.ExternalFunction("malloc_usable_size", types.uintp(types.uintp))
_memset = types.ExternalFunction("memset", types.uintp(types.uintp, types.int32, types.uintp))
_memcpy = types.ExternalFunction("memcpy", types.uintp(types.uintp, types.uintp, types.uintp))
_madvise = types.ExternalFunction("madvise", types.int32(types.uintp, types.uintp, types.int32))
_MADV_DONTNEED = 4


@intrinsic
def _words(typingctx, address):
    """The 64-bit words at ``address`` (an integer), as a pointer numba can index."""
    signature = types.CPointer(types.uint64)(types.uintp)

    def codegen(context, builder, sig, args):
        return builder.inttoptr(args[0], context.get_value_type(sig.return_type))

    return signature, codegen



def new_state(base: int, size: int) -> np.ndarray:
    """The allocator's table for a region of ``size`` bytes at ``base``."""
    state = np.zeros(FIRST + 2 * RANGES, np.uint64)
    state[BASE], state[SIZE] = base, size
    return state


@compiled
def _table(ctx):
    return carray(_words(ctx), FIRST + 2 * RANGES)


@compiled
def _get(table, i):
    """Word ``i`` of the table as a signed integer (sizes and offsets are far below 2^63)."""
    return np.int64(table[i])


@compiled
def _address(base, offset):
    return np.uint64(base) + np.uint64(offset)


@compiled
def _remove(table, i):
    count = _get(table, COUNT)
    for j in range(i, count - 1):
        table[FIRST + 2 * j] = table[FIRST + 2 * j + 2]
        table[FIRST + 2 * j + 1] = table[FIRST + 2 * j + 3]
    table[COUNT] = np.uint64(count - 1)


@compiled
def _take(table, need):
    """Offset of ``need`` bytes in the region (best fit: the smallest free
    range that holds them, else the top), or -1 if none are left."""
    count = _get(table, COUNT)
    best = -1  # the smallest range that holds it: first fit left a peak 50 MB higher on the 1 km city
    for i in range(count):
        size = _get(table, FIRST + 2 * i + 1)
        if size >= need and (best < 0 or size < _get(table, FIRST + 2 * best + 1)):
            best = i
            if size == need:
                break
    if best >= 0:
        offset, size = _get(table, FIRST + 2 * best), _get(table, FIRST + 2 * best + 1)
        if size == need:
            _remove(table, best)
        else:
            table[FIRST + 2 * best] = np.uint64(offset + need)
            table[FIRST + 2 * best + 1] = np.uint64(size - need)
        return offset
    top = _get(table, TOP)
    if top + need > _get(table, SIZE):
        return np.int64(-1)
    table[TOP] = np.uint64(top + need)
    if top + need > _get(table, HIGH):
        table[HIGH] = np.uint64(top + need)
    return top


@compiled
def _give(table, offset, size):
    """Return a range to the free ranges, merged with its neighbours; the top
    comes down to it where it ends there (so no free range ends at the top)."""
    count = _get(table, COUNT)
    low, high = np.int64(0), count  # the first range after it
    while low < high:
        middle = (low + high) // 2
        if _get(table, FIRST + 2 * middle) < offset:
            low = middle + 1
        else:
            high = middle
    i = low
    if i > 0 and _get(table, FIRST + 2 * i - 2) + _get(table, FIRST + 2 * i - 1) == offset:
        i -= 1
        offset = _get(table, FIRST + 2 * i)
        size += _get(table, FIRST + 2 * i + 1)
        _remove(table, i)
        count -= 1
    if i < count and offset + size == _get(table, FIRST + 2 * i):
        size += _get(table, FIRST + 2 * i + 1)
        _remove(table, i)
        count -= 1
    if offset + size == _get(table, TOP):
        table[TOP] = np.uint64(offset)
        return
    if count == RANGES:  # no room to remember it: its pages go back, its space stays unused
        _madvise(_address(table[BASE], offset), np.uint64(size), _MADV_DONTNEED)
        return
    for j in range(count, i, -1):
        table[FIRST + 2 * j] = table[FIRST + 2 * j - 2]
        table[FIRST + 2 * j + 1] = table[FIRST + 2 * j - 1]
    table[FIRST + 2 * i] = np.uint64(offset)
    table[FIRST + 2 * i + 1] = np.uint64(size)
    table[COUNT] = np.uint64(count + 1)


@compiled
def _allocate(ctx, size, zero):
    need = np.int64(size) + HEADER
    if need >= LARGE:
        table = _table(ctx)
        need = (need + PAGE - 1) // PAGE * PAGE
        offset = _take(table, need)
        if offset >= 0:
            block = _address(table[BASE], offset)
            if zero:
                _memset(block + np.uint64(HEADER), 0, np.uint64(size))
            header = carray(_words(block), 2)
            header[0], header[1] = np.uint64(need), np.uint64(1)
            return block + np.uint64(HEADER)
    block = _calloc(np.uint64(1), np.uint64(need)) if zero else _malloc(np.uint64(need))  # small, or no room
    if block == 0:
        return np.uint64(0)
    header = carray(_words(block), 2)
    header[0], header[1] = np.uint64(0), np.uint64(0)
    return block + np.uint64(HEADER)


@compiled
def _release(ctx, data):
    if data == 0:
        return
    block = data - np.uint64(HEADER)
    header = carray(_words(block), 2)
    if header[1] == 0:
        _free(block)
        return
    table = _table(ctx)
    _give(table, np.int64(block - table[BASE]), np.int64(header[0]))


@numba.cfunc(types.uintp(types.uintp, types.uintp), cache=True)
def array_malloc(ctx, size):
    """``malloc`` of numpy's ``PyDataMem_Handler``."""
    return _allocate(ctx, size, False)


@numba.cfunc(types.uintp(types.uintp, types.uintp, types.uintp), cache=True)
def array_calloc(ctx, count, size):
    """``calloc`` of numpy's ``PyDataMem_Handler``: zeroed bytes."""
    if size != 0 and count > np.uint64(2**62) // size:
        return np.uint64(0)
    return _allocate(ctx, count * size, True)


@numba.cfunc(types.uintp(types.uintp, types.uintp, types.uintp), cache=True)
def array_realloc(ctx, data, size):
    """``realloc`` of numpy's ``PyDataMem_Handler``: a block of ``size`` bytes
    with the old block's first bytes, which it may replace."""
    if data == 0:
        return _allocate(ctx, size, False)
    block = data - np.uint64(HEADER)
    header = carray(_words(block), 2)
    if header[1] == 0:
        if np.int64(size) + HEADER < LARGE:
            moved = _realloc(block, size + np.uint64(HEADER))
            return np.uint64(0) if moved == 0 else moved + np.uint64(HEADER)
        held = _usable_size(block) - np.uint64(HEADER)
    else:
        held = header[0] - np.uint64(HEADER)
        if size <= held:
            return data
    moved = _allocate(ctx, size, False)
    if moved != 0:
        _memcpy(moved, data, held if held < size else size)
        _release(ctx, data)
    return moved


@numba.cfunc(types.void(types.uintp, types.uintp, types.uintp), cache=True)
def array_free(ctx, data, size):
    """``free`` of numpy's ``PyDataMem_Handler``."""
    _release(ctx, data)


def return_free_pages(state: np.ndarray) -> int:
    """Hand the pages of the free ranges, and those above the top, back to
    the system (their space stays reserved); the bytes handed back."""
    return int(_return_free_pages(state))


@numba.njit(cache=True)  # with the GIL: no thread may take a free range while its pages go
def _return_free_pages(state):
    base, returned = state[BASE], np.int64(0)
    for i in range(_get(state, COUNT)):
        offset, size = _get(state, FIRST + 2 * i), _get(state, FIRST + 2 * i + 1)
        _madvise(_address(base, offset), np.uint64(size), _MADV_DONTNEED)
        returned += size
    top, high = _get(state, TOP), _get(state, HIGH)
    if high > top:
        _madvise(_address(base, top), np.uint64(high - top), _MADV_DONTNEED)
        returned += high - top
        state[HIGH] = np.uint64(top)
    return returned


def warm_up() -> int:
    """Compile the four functions and the pages' return (or load them from the cache)."""
    state = new_state(0, 0)
    assert return_free_pages(state) == 0
    return len([array_malloc.address, array_calloc.address, array_realloc.address, array_free.address])
