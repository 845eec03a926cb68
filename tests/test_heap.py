"""The allocator settings of a run: freed memory reused inside, faulted in ahead, handed back after."""
import ctypes
import os
import subprocess
import sys
from pathlib import Path

import pytest

from core import array_heap, heap

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.skipif(heap._LIBC is None, reason="glibc only")

_PROBE = """
import sys, time
import numpy as np
from core import array_heap
from core.heap import host_threads, release, reusing_freed_memory

def rss_mb():
    return int(open("/proc/self/statm").read().split()[1]) * 4096 / 2**20

# In a host process the arrays come from core.array_heap: loaded first (numba
# takes some 100 MB), so that the memory measured is the arrays'.
assert host_threads() == (sys.argv[2] == "host") and (sys.argv[2] != "host" or array_heap.available())
start = rss_mb()
with reusing_freed_memory():
    with reusing_freed_memory():  # nested, as tiles and clusters call the pipeline
        block = np.ones(50_000_000 // 8); del block  # 50 MB, above glibc's largest mmap threshold
    kept = rss_mb() - start
    again = np.ones(50_000_000 // 8)  # served from the memory kept, not faulted in
    reused = rss_mb() - start
    del again
after = rss_mb() - start
with reusing_freed_memory():  # the next run, within the time kept
    # 40 MB: the 50 MB kept may have served a few small blocks meanwhile (the timer thread's).
    again = np.ones(40_000_000 // 8); del again
next_run = rss_mb() - start
if sys.argv[1] == "release":
    release()
elif sys.argv[1] == "wait":
    time.sleep(1.0)
released = rss_mb() - start
print(kept, reused, after, next_run, released)
"""


def _probe(keep_seconds: str, then: str, process: str) -> list[float]:
    """The probe in a process of its own: ``process`` "one heap" as the
    command line's (glibc's first heap for every thread), or "host" (threads
    with arenas of their own: numpy's arrays from core.array_heap)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "URBANVOX_KEEP_MEMORY_SECONDS": keep_seconds}
    env.pop("MALLOC_ARENA_MAX", None)
    if process == "one heap":
        env["MALLOC_ARENA_MAX"] = "1"
    out = subprocess.run([sys.executable, "-c", _PROBE, then, process], cwd=ROOT, capture_output=True, text=True,
                         env=env, check=True).stdout
    return [float(value) for value in out.split()]


_PROCESSES = ["one heap", pytest.param("host", marks=pytest.mark.skipif(
    not array_heap.available(), reason="core.array_heap needs numba and numpy's headers"))]


@pytest.mark.parametrize("process", _PROCESSES)
def test_freed_memory_is_kept_inside_and_handed_back_after(process):
    kept, reused, after, _, _ = _probe("0", "nothing", process)
    assert kept > 45  # the 50 MB freed stayed in the process
    assert reused < kept + 5  # and served the next 50 MB
    assert after < 5  # all handed back when the last user left


@pytest.mark.parametrize("process", _PROCESSES)
def test_freed_memory_serves_the_next_run_then_is_handed_back(process):
    # Kept for a minute after a run (the default), the heap serves a run that
    # starts meanwhile without growing; release() hands it back at once.
    kept, _, after, next_run, released = _probe("", "release", process)
    assert kept > 45
    assert after > 45  # still kept after the last user left
    assert next_run < after + 5  # the next run reused it
    assert released < 5
    # With a short time kept, the timer hands it back by itself.
    *_, next_run, released = _probe("0.2", "wait", process)
    assert next_run > 45 and released < 5


def test_no_amount_of_freed_memory_is_handed_back_inside(monkeypatch):
    # glibc trims the heap's top when the free space there reaches the trim
    # threshold: the largest positive value mallopt takes (2 GB) let the 2 km
    # city's tile merge hand back 2.4 GB and fault it in again. -1 disables
    # trimming (mallopt(3)); a probe freeing over 2 GB would be too slow here.
    calls = []

    class Recorder:
        def mallopt(self, parameter, value):
            calls.append((parameter, value))
            return 1

        def malloc_trim(self, pad):
            calls.append(("trim", pad))
            return 1

    monkeypatch.setattr(heap, "_LIBC", Recorder())
    monkeypatch.setattr(heap, "_set_huge_pages", lambda enabled: None)
    monkeypatch.setattr(heap, "_applied", False)  # this test's own state, whatever a run left
    monkeypatch.setattr(heap, "_release_timer", None)
    monkeypatch.setenv("URBANVOX_KEEP_MEMORY_SECONDS", "0")
    with heap.reusing_freed_memory():
        assert calls == [(heap._M_MMAP_THRESHOLD, 2**31 - 1), (heap._M_TRIM_THRESHOLD, -1)]
    assert calls[2:] == [(heap._M_MMAP_THRESHOLD, 128 * 1024), (heap._M_TRIM_THRESHOLD, 128 * 1024), ("trim", 0)]
    assert heap.WORKER_ENVIRONMENT["MALLOC_TRIM_THRESHOLD_"] == "-1"


def test_worker_environment_is_scoped_to_the_cluster_start():
    pytest.importorskip("dask")
    import dask

    from core.workers import _worker_environment

    before = dict(os.environ)
    with _worker_environment(2):
        spawn = dask.config.get("distributed.nanny.pre-spawn-environ")
        assert spawn["MALLOC_ARENA_MAX"] == "1"
        assert spawn["MALLOC_TRIM_THRESHOLD_"] == heap.WORKER_ENVIRONMENT["MALLOC_TRIM_THRESHOLD_"]
        assert int(spawn["URBANVOX_THREADS"]) == max(1, (os.cpu_count() or 1) // 2)
        os.environ.update({k: str(v) for k, v in spawn.items()})  # what a nanny does before spawning
    assert dict(os.environ) == before


def test_numpy_huge_page_requests_are_off_during_a_run_only():
    heap.release()  # a run of another test may have left its settings, kept for the next
    before = heap._set_huge_pages(True)
    try:
        with heap.reusing_freed_memory():
            assert heap._set_huge_pages(False) is False  # off inside (the call returns the setting it replaced)
        assert heap._set_huge_pages(False) is False  # still off while the heap is kept for the next run
        heap.release()
        assert heap._set_huge_pages(True) is True  # and back on after
    finally:
        heap._set_huge_pages(before)


_THREAD_PROBE = """
import resource, sys, threading
import numpy as np
from core.heap import one_arena, reusing_freed_memory

if sys.argv[1] == "one":
    assert one_arena()
faults = []

def work():
    # 100 MB made and freed on a new thread, three times: above the 64 MB a
    # thread's own arena can hold, so there it comes from fresh pages each time.
    for _ in range(3):
        before = resource.getrusage(resource.RUSAGE_THREAD).ru_minflt
        block = np.ones(100_000_000 // 8)
        del block
        faults.append(resource.getrusage(resource.RUSAGE_THREAD).ru_minflt - before)

with reusing_freed_memory():
    for _ in range(2):
        thread = threading.Thread(target=work)
        thread.start()
        thread.join()
print(sum(faults[1:]))
"""


@pytest.mark.parametrize("arena", ["one", "default"])
def test_one_arena_lets_threads_reuse_the_freed_memory(arena):
    # 100 MB is 24,400 pages: with one arena, every allocation after the
    # first is served from the memory the first took; with an arena per
    # thread, each faults its pages in again.
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("MALLOC_ARENA_MAX", None)
    out = subprocess.run([sys.executable, "-c", _THREAD_PROBE, arena], cwd=ROOT, capture_output=True, text=True,
                         env=env, check=True).stdout
    faults = int(out)
    if arena == "one":
        assert faults < 2_000
    else:
        assert faults > 5 * 24_000


_AHEAD_PROBE = """
import resource, sys
import numpy as np
from core import array_heap, heap

def faults():
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt

def rss_mb():
    return int(open("/proc/self/statm").read().split()[1]) * 4096 / 2**20

assert heap.host_threads() == (sys.argv[2] == "host") and (sys.argv[2] != "host" or array_heap.available())
start = rss_mb()
with heap.reusing_freed_memory():
    thread = heap.fault_in_ahead(200 * 2**20) if sys.argv[1] == "ahead" else None
    if thread is not None:
        thread.join()
    ahead = rss_mb() - start
    before = faults()
    block = np.ones(150 * 2**20 // 8)  # 38,400 pages written
    taken = faults() - before
    del block
    again = heap.fault_in_ahead(200 * 2**20)  # the heap holds it now: nothing to do
    # 2 GB asked, and the run ends at once: the thread stops there.
    big = heap.fault_in_ahead(2 * 2**30)
big is None or big.join(timeout=60)
stopped = (big is None or not big.is_alive()) and rss_mb() - start < 1000  # not the 2 GB
heap.release()
print(thread is not None, ahead, taken, again is None, stopped, rss_mb() - start)
"""


def _populate_works() -> bool:
    import mmap

    area = mmap.mmap(-1, 1 << 20)
    address = ctypes.addressof(ctypes.c_char.from_buffer(area))
    try:
        return heap._LIBC.madvise(address, 1 << 20, heap._MADV_POPULATE_WRITE) == 0
    finally:
        area.close()


@pytest.mark.parametrize("process", _PROCESSES)
def test_a_runs_memory_is_faulted_in_ahead_and_handed_back(process):
    # The pages of a run's estimate, faulted in by a thread of their own: the
    # run's arrays then take them without faults, unchanged, and they go back
    # with the rest of the heap.
    if not _populate_works():
        pytest.skip("the kernel has no MADV_POPULATE_WRITE (Linux 5.14)")
    # The heap kept after the run (the default), so that what the stopped thread left shows.
    env = {**os.environ, "PYTHONPATH": str(ROOT), "URBANVOX_KEEP_MEMORY_SECONDS": "60"}
    env.pop("MALLOC_ARENA_MAX", None)
    if process == "one heap":
        env["MALLOC_ARENA_MAX"] = "1"
    results = {}
    for how in ("ahead", "not"):
        out = subprocess.run([sys.executable, "-c", _AHEAD_PROBE, how, process], cwd=ROOT, capture_output=True,
                             text=True, env=env, check=True).stdout.split()
        results[how] = out[0] == "True", float(out[1]), int(out[2]), out[3] == "True", out[4] == "True", \
            float(out[5])
    started, ahead, taken, nothing_again, stopped, released = results["ahead"]
    assert started and ahead > 150  # 200 MB in, less what the heap held free
    assert taken < 2_000  # against 38,400 pages
    assert nothing_again and stopped and released < 20
    started, ahead, taken, _, stopped, released = results["not"]
    assert not started and ahead < 20 and taken > 35_000 and stopped and released < 20


_HELD_PROBE = """
import sys
import numpy as np
from core import array_heap, heap, memory

assert heap.host_threads() == (sys.argv[1] == "host") and (sys.argv[1] != "host" or array_heap.available())
memory._system_available = lambda: 0  # what the guard counts beyond the system's figure
start = heap.held_free_bytes()
with heap.reusing_freed_memory():
    block = np.ones(400 * 2**20 // 8); del block  # 400 MB written, then freed: the heap keeps it
    held, counted = heap.held_free_bytes(), memory.available_memory()
    again = np.ones(300 * 2**20 // 8)  # takes 300 MB of it
    left = heap.held_free_bytes()
    del again
    # 200 MB freed in holes between blocks in use: glibc's count keeps them once handed back.
    blocks = [np.ones(100_000 // 8) for _ in range(4000)]
    del blocks[::2]
heap.release()
released = heap.held_free_bytes()
# Memory other than the heaps' blocks (Python's own small objects: 10 M ints) does not make
# the pages handed back count again.
numbers = list(range(10_000_000))
print(*(round(size / 2**20) for size in (start, held, counted, left, released, heap.held_free_bytes())))
"""


@pytest.mark.parametrize("process", _PROCESSES)
def test_the_memory_guard_counts_what_the_heap_holds_free(process):
    # The system's MemAvailable leaves out the memory a run freed and its
    # heap keeps: the guard counts it beside, as long as the heap holds it.
    env = {**os.environ, "PYTHONPATH": str(ROOT), "URBANVOX_KEEP_MEMORY_SECONDS": "60"}
    env.pop("MALLOC_ARENA_MAX", None)
    if process == "one heap":
        env["MALLOC_ARENA_MAX"] = "1"
    out = subprocess.run([sys.executable, "-c", _HELD_PROBE, process], cwd=ROOT, capture_output=True, text=True,
                         env=env, check=True).stdout
    start, held, counted, left, released, beside_others = (int(value) for value in out.split())
    assert start < 50
    assert 390 <= held - start <= 420 and abs(counted - held) < 10
    assert 90 <= left - start <= 120  # the 100 MB the next array left
    assert released < 20 and beside_others < 20  # handed back: in the system's figure again, not counted twice


_LAZY_PROBE = """
import sys
from core import array_heap, heap
from core.parallel import map_blocks, thread_count

assert heap.host_threads() and thread_count() > 1
def on_region(_):
    return array_heap.in_use_here()
outside = heap.use_array_heap_here(load=True)  # not during a run: nothing
with heap.reusing_freed_memory():  # a small run: numba never comes
    small = ["numba" in sys.modules, array_heap.in_use_here(), any(map_blocks(on_region, range(8)))]
with heap.reusing_freed_memory():  # a large one: the reader asks before its points
    loaded = heap.use_array_heap_here(load=True)
    large = [array_heap.in_use_here(), all(map_blocks(on_region, range(8)))]
print(outside, small, loaded, large, array_heap.in_use_here())
"""


@pytest.mark.skipif(not array_heap.available(), reason="core.array_heap needs numba and numpy's headers")
def test_a_hosts_small_run_does_not_load_numba_for_the_array_heap():
    # The region's allocator is compiled with numba: a run too small for the
    # kernels keeps glibc; a large one (the reader's load) and the pool's
    # threads then take the region, and the run's end gives its thread back.
    env = {**os.environ, "PYTHONPATH": str(ROOT), "URBANVOX_THREADS": "2"}
    env.pop("MALLOC_ARENA_MAX", None)
    env.pop("URBANVOX_JIT", None)
    out = subprocess.run([sys.executable, "-c", _LAZY_PROBE], cwd=ROOT, capture_output=True, text=True, env=env,
                         check=True).stdout.strip()
    assert out == "False [False, False, False] True [True, True] False"
