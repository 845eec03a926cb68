"""Row blocks on threads: the results of one pass, in order."""
import numpy as np
import pytest

from core import parallel
from core.parallel import map_blocks, row_blocks


def test_blocks_cover_the_rows_once_in_order():
    blocks = row_blocks(10_001, 1000)
    assert len(blocks) == 11 and blocks[0].start == 0 and blocks[-1].stop == 10_001
    assert all(a.stop == b.start for a, b in zip(blocks, blocks[1:]))
    assert row_blocks(0, 10) == []


def test_threads_give_the_numbers_of_one_pass(monkeypatch):
    rng = np.random.default_rng(0)
    x = rng.random((100_000, 12, 3))
    w = rng.random((100_000, 12))

    def centre(rows):
        return np.einsum("qk,qkc->qc", w[rows], x[rows])

    one_pass = centre(slice(None))
    for threads in ("1", "2", "3"):
        monkeypatch.setenv("URBANVOX_THREADS", threads)
        assert parallel.thread_count() == int(threads)
        blocks = np.concatenate(map_blocks(centre, row_blocks(len(x), 4096)))
        assert np.array_equal(blocks, one_pass)


def test_a_failing_block_raises_in_the_caller(monkeypatch):
    monkeypatch.setenv("URBANVOX_THREADS", "2")

    def fail(rows):
        if rows.start == 4:
            raise ValueError("block 2")
        return rows.start

    with pytest.raises(ValueError, match="block 2"):
        map_blocks(fail, row_blocks(10, 4))


def test_background_work_runs_on_its_own_thread_unless_one_thread_is_asked(monkeypatch):
    import threading

    from core.parallel import in_background

    def where_and_double(x):
        return threading.get_ident(), 2 * x

    here = threading.get_ident()
    monkeypatch.setenv("URBANVOX_THREADS", "2")
    ident, value = in_background(where_and_double, 21).result()
    assert value == 42 and ident != here
    monkeypatch.setenv("URBANVOX_THREADS", "1")
    ident, value = in_background(where_and_double, 21).result()
    assert value == 42 and ident == here
    for threads in ("1", "2"):
        monkeypatch.setenv("URBANVOX_THREADS", threads)
        with pytest.raises(ZeroDivisionError):
            in_background(lambda: 1 / 0).result()


def test_the_pipeline_gives_the_same_model_with_one_thread_or_more(monkeypatch, district, compiled):
    # The KD-trees are built in the background with threads, here without:
    # the same nodes and blocks either way. With the kernels (loaded: they
    # then run for any size), and on three threads with balanced blocks of
    # 64 rows: the kernels that share rows out that way (each writes its own
    # rows only) give the same model.
    from core.pipeline import ReconstructionParams, reconstruct_point_cloud

    compiled("quality_kernel")
    results = []
    for threads, rows in (("1", parallel.BALANCED_ROWS), ("2", parallel.BALANCED_ROWS), ("3", 64)):
        monkeypatch.setenv("URBANVOX_THREADS", threads)
        monkeypatch.setattr(parallel, "BALANCED_ROWS", rows)
        results.append(reconstruct_point_cloud(district.laz, crs=district.crs,
                                               params=ReconstructionParams(voxel_size=1.0)))
    assert len(results[0].blocks) > 20
    for other in results[1:]:
        assert np.array_equal(results[0].mesh.nodes, other.mesh.nodes)
        assert results[0].block_rows() == other.block_rows()


def test_balanced_blocks_cover_the_rows_once_in_order_a_few_per_thread(monkeypatch):
    monkeypatch.setenv("URBANVOX_THREADS", "3")
    blocks = parallel.balanced_blocks(1_000_003)
    assert len(blocks) == 3 * parallel.BALANCED_PER_THREAD
    assert blocks[0].start == 0 and blocks[-1].stop == 1_000_003
    assert all(a.stop == b.start for a, b in zip(blocks, blocks[1:]))
    # Small work: one block per thread, as thread_blocks.
    assert parallel.balanced_blocks(1000) == parallel.thread_blocks(1000) and len(parallel.thread_blocks(1000)) == 3


def test_a_pool_in_hand_still_runs_after_another_count_is_asked(monkeypatch):
    # The kernels' preload held the pool of the cores while a test asked for
    # three threads: the new pool shut the old one down under it.
    held = parallel._executor(2)
    monkeypatch.setenv("URBANVOX_THREADS", "3")
    assert np.concatenate(map_blocks(lambda rows: np.arange(rows.start, rows.stop), row_blocks(10, 4))).sum() == 45
    assert list(held.map(abs, [-1, -2, -3])) == [1, 2, 3]


def test_blocks_ahead_come_in_order_while_the_caller_works(monkeypatch):
    """map_ahead: the results in the blocks' order, at most two blocks per
    thread made ahead of the one taken, and a failing block raises in the caller."""
    import threading

    from core.parallel import map_ahead

    started, taken = [], []
    lock = threading.Lock()

    def square(n):
        with lock:
            started.append(n)
        return n * n

    for threads in ("1", "3"):
        monkeypatch.setenv("URBANVOX_THREADS", threads)
        started.clear()
        taken.clear()
        for n, result in zip(range(40), map_ahead(square, range(40))):
            assert result == n * n
            with lock:
                assert len(started) <= n + 1 + 2 * int(threads) * (threads != "1")
            taken.append(n)
        assert taken == list(range(40)) and sorted(started) == list(range(40))
    monkeypatch.setenv("URBANVOX_THREADS", "2")
    with pytest.raises(ZeroDivisionError):
        list(map_ahead(lambda n: 1 / (n - 5), range(10)))


@pytest.mark.parametrize("threads", ["1", "3"])
def test_rows_taken_on_all_cores_are_numpys(monkeypatch, threads):
    """take_rows gathers the rows numpy's take gathers (tables of one and of
    three columns, of floats, ints and booleans), in blocks on three
    threads, and refuses an index out of range as numpy does."""
    monkeypatch.setenv("URBANVOX_THREADS", threads)
    monkeypatch.setattr(parallel, "TAKE_ROWS_PARALLEL", 1000)
    monkeypatch.setattr(parallel, "BALANCED_ROWS", 700)
    rng = np.random.default_rng(4)
    index = rng.integers(0, 50_000, 20_001)
    for table in (rng.normal(size=(50_000, 3)), rng.integers(-9, 9, 50_000).astype(np.int32),
                  rng.random(50_000) < 0.5):
        expected = table.take(index, axis=0)
        got = parallel.take_rows(table, index)
        assert got.dtype == expected.dtype and np.array_equal(got, expected)
    if threads == "3":
        assert len(parallel.balanced_blocks(len(index))) > 3
    index[-5] = 50_000
    with pytest.raises(IndexError):
        parallel.take_rows(table, index)
