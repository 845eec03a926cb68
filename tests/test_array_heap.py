"""numpy's arrays from core.array_heap's region: contents kept, freed ranges merged and reused, pages handed back."""
import threading

import numpy as np
import pytest

from core import array_heap
from core.heap import numpy_core

pytestmark = pytest.mark.skipif(not array_heap.available(), reason="core.array_heap needs numba and numpy's headers")

MB = 1 << 20


def _handler_name(array=None) -> str:
    get = numpy_core().multiarray.get_handler_name
    return get() if array is None else get(array)


@pytest.fixture
def on_region():
    assert array_heap.use_on_this_thread()
    try:
        yield
    finally:
        array_heap.stop_on_this_thread()


def _rss_mb() -> float:
    return int(open("/proc/self/statm").read().split()[1]) * 4096 / MB


def test_only_the_thread_that_asks_uses_it_and_gets_its_own_back():
    before = _handler_name()
    seen = {}
    assert array_heap.use_on_this_thread() and array_heap.use_on_this_thread()  # nested
    try:
        thread = threading.Thread(target=lambda: seen.update(other=_handler_name()))
        thread.start()
        thread.join()
        large = np.ones(2 * MB)
        assert _handler_name() == _handler_name(large) == "urbanvox_array_heap"
        array_heap.stop_on_this_thread()
        assert array_heap.in_use_here()  # the outer use goes on
    finally:
        array_heap.stop_on_this_thread()
    assert not array_heap.in_use_here() and _handler_name() == before
    assert seen["other"] == before
    # An array keeps the allocator that made it, and frees into it.
    assert _handler_name(large) == "urbanvox_array_heap" and large.sum() == 2 * MB
    del large


def test_contents_survive_any_order_of_allocations_and_frees(on_region):
    """Arrays of 1 byte to 6 MB (glibc's and the region's), made with
    ``empty``, ``zeros`` and ``full``, grown and shrunk with ``resize``, freed
    in random order: each keeps its values, and ``zeros`` are zeros in
    memory that held others' values."""
    rng = np.random.default_rng(5)
    live: dict[int, tuple[np.ndarray, int]] = {}
    for step in range(4000):
        key = int(rng.integers(0, 60))
        if key in live:
            array, value = live.pop(key)
            assert (array == value).all(), step
            if rng.random() < 0.3:  # grown or shrunk in place or moved, its first bytes kept
                n = len(array)
                array.resize(int(rng.integers(1, 6 * MB)), refcheck=False)
                assert (array[:n] == value).all(), step
                array[n:] = value
                live[key] = (array, value)
            continue
        n, value = int(rng.integers(1, 6 * MB)), step % 251 + 1
        kind = rng.integers(0, 3)
        if kind == 0:
            array = np.zeros(n, np.uint8)
            assert not array.any(), step
            array += value
        elif kind == 1:
            array = np.empty(n, np.uint8)
            array.fill(value)
        else:
            array = np.full(n, value, np.uint8)
        live[key] = (array, value)
    for array, value in live.values():
        assert (array == value).all()


def _take_free_ranges() -> list:
    """Arrays that take the region's free ranges of a large block or more,
    left by earlier tests (best fit: each one exactly), so that the next
    large arrays come from the region's top."""
    header = array_heap._kernel.HEADER
    return [np.empty(size - header, np.uint8) for size in array_heap.free_sizes() if size >= array_heap._kernel.LARGE]


def test_freed_ranges_merge_and_serve_the_next_arrays(on_region):
    held = _take_free_ranges()
    assert max(array_heap.free_sizes(), default=0) < array_heap._kernel.LARGE
    top, free = array_heap.region_in_use()
    a, b, c = (np.ones(8 * MB // 8) for _ in range(3))  # 8 MB each, one after another in the region
    grown, _ = array_heap.region_in_use()
    assert grown - top >= 3 * 8 * MB
    del a, b  # two neighbours: one free range
    now_top, now_free = array_heap.region_in_use()
    assert now_top == grown and now_free - free >= 2 * 8 * MB
    d = np.ones(2 * 8 * MB // 8)  # fits in the merged range: the top does not move
    assert array_heap.region_in_use()[0] == grown
    del c, d  # the last block before the top: the top comes down
    assert array_heap.region_in_use()[0] <= top
    del held


def test_free_pages_are_handed_back(on_region):
    array_heap.return_free_pages()
    block = np.ones(200 * MB // 8)
    held = _rss_mb()
    del block  # kept for the next array: still resident
    assert _rss_mb() > held - 20
    returned = array_heap.return_free_pages()
    assert returned >= 200 * MB and _rss_mb() < held - 150
