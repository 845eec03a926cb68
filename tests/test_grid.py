"""Tests of core/grid.py's binning: the same cells, in the same order, as np.unique, with
numpy's passes and with the compiled kernel (core.grid_kernel)."""

from __future__ import annotations

import numpy as np
import pytest

from core.grid import VoxelGrid


@pytest.fixture(params=["numpy", "compiled"], autouse=True)
def binning(request, monkeypatch, compiled):
    """Every test runs on numpy's binning and on the kernel's (for any size)."""
    if request.param == "numpy":
        monkeypatch.setenv("URBANVOX_JIT", "0")
    else:
        monkeypatch.setenv("URBANVOX_JIT", "always")
        compiled("grid_kernel")
    return request.param


def unique_cells(grid: VoxelGrid, points: np.ndarray) -> np.ndarray:
    """The reference: distinct voxel numbers by sorting (what core.pipeline did first)."""
    nx, ny, _ = grid.shape
    number = np.unique(grid.voxel_number(grid.cell_of(points)))
    return np.column_stack([number % nx, (number // nx) % ny, number // (nx * ny)])


def grid_around(points: np.ndarray, h: float) -> VoxelGrid:
    """The pipeline's lattice: multiples of h, one layer under the data, one empty layer on top."""
    lower = np.floor(points.min(axis=0) / h) * h - np.array([0.0, 0.0, h])
    return VoxelGrid.around(np.zeros(3), points.max(axis=0) - lower, h, offset=lower, extra_top=1)


@pytest.mark.parametrize("h", [1.0, 0.5, 0.3, 2.0])
@pytest.mark.parametrize("chunk,threads", [(7, "1"), (1000, "3"), (1 << 16, "2")])
def test_random_points_match_unique(h, chunk, threads, monkeypatch):
    # Threads: the kernel's bitmaps, one per thread (of 1000 points or more here), merged.
    monkeypatch.setenv("URBANVOX_THREADS", threads)
    monkeypatch.setattr("core.grid_kernel._THREAD_POINTS", 1000)
    rng = np.random.default_rng(int(h * 10) + chunk)
    points = rng.random((20_000, 3)) * np.array([60.0, 40.0, 25.0])
    grid = grid_around(points, h)
    local = points - grid.offset
    cells = grid.occupied_cells(local, chunk=chunk)
    np.testing.assert_array_equal(cells, unique_cells(grid, local))
    occupancy = grid.occupancy(local, chunk=chunk)
    assert occupancy.shape == grid.shape and occupancy.sum() == len(cells)


def test_points_on_cell_boundaries_and_outside_the_grid_are_clipped_alike():
    grid = VoxelGrid(np.zeros(3), np.array([0.0, 0.0, -1.0]), 0.5, (6, 5, 4))
    edges = np.array([0.0, 0.5, 1.0, 2.5, 3.0, -0.5, 7.25, 1e6, -1e6])
    points = np.stack(np.meshgrid(edges, edges, edges, indexing="ij"), axis=-1).reshape(-1, 3)
    np.testing.assert_array_equal(grid.occupied_cells(points), unique_cells(grid, points))


def test_voxels_at_every_place_of_a_bitmap_word_are_listed():
    """The kernel's bitmap holds 64 voxels a word: every place, first and last voxel included."""
    grid = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (7, 11, 5))
    rng = np.random.default_rng(5)
    for number in (np.arange(grid.n_voxels), rng.choice(grid.n_voxels, 40, replace=False), [0, grid.n_voxels - 1]):
        ijk = np.column_stack([np.asarray(number) % 7, (np.asarray(number) // 7) % 11, np.asarray(number) // 77])
        points = ijk + 0.5
        np.testing.assert_array_equal(grid.occupied_cells(points), ijk[np.argsort(number)])


def test_bitmaps_written_in_different_words_by_each_thread_merge_to_np_unique(monkeypatch):
    """The kernel's threads write only some words of their bitmaps (the
    others are never zeroed): cells seen by one thread, by several, in runs
    along x and alone, over words and summary words written by one thread only."""
    monkeypatch.setenv("URBANVOX_THREADS", "3")
    monkeypatch.setattr("core.grid_kernel._THREAD_POINTS", 50)
    grid = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (130, 9, 7))
    rng = np.random.default_rng(11)
    runs = np.column_stack([np.arange(0, 130), np.full(130, 4), np.full(130, 2)]) + 0.5
    alone = rng.random((400, 3)) * np.array(grid.shape)
    for points in (np.concatenate([runs, alone]), np.concatenate([alone[:100], runs[::7], alone[100:], runs[3::5]]),
                   np.tile([[129.5, 8.5, 6.5], [0.5, 0.5, 0.5]], (200, 1))):
        np.testing.assert_array_equal(grid.occupied_cells(points), unique_cells(grid, points))


def test_columns_are_those_of_cell_of_on_boundaries_and_outside_the_grid():
    grid = VoxelGrid(np.zeros(3), np.array([0.0, 0.0, -1.0]), 0.5, (6, 5, 4))
    edges = np.array([0.0, 0.5, 1.0, 2.5, 3.0, -0.5, 7.25, 1e6, -1e6, 0.49999999999999994])
    points = np.stack(np.meshgrid(edges, edges, edges, indexing="ij"), axis=-1).reshape(-1, 3)
    cells = grid.cell_of(points)
    for chunk in (7, 1 << 16):
        np.testing.assert_array_equal(grid.column_of(points, chunk=chunk), cells[:, 0] * 5 + cells[:, 1])


def test_las_like_points_with_large_offsets_match_unique():
    """Coordinates stored to the millimetre at LV95 magnitudes, many exactly on voxel
    boundaries, in acquisition (scan-line) order: the real files' case."""
    rng = np.random.default_rng(3)
    n = 300_000
    line = np.sort(rng.integers(0, 400, n))  # scan lines along y, in order
    x = 2_600_000.0 + np.round(rng.random(n) * 120.0, 3)
    y = 1_200_000.0 + line * 0.25 + np.round(rng.random(n) * 0.25, 3)
    z = 400.0 + np.round(rng.random(n) * 30.0 * (rng.random(n) < 0.5), 3)
    world = np.column_stack([x, y, z])
    for h in (1.0, 0.5):
        grid = grid_around(world, h)
        local = world - grid.offset
        np.testing.assert_array_equal(grid.occupied_cells(local), unique_cells(grid, local))


def test_real_file_points_match_unique(shared_data):
    from core.readers.las import read_point_clouds

    points = read_point_clouds(str(shared_data / "delft_ahn3/ahn3_cropped_2.laz"), crs="EPSG:28992")
    for h in (1.0, 0.5):
        grid = grid_around(np.concatenate([points.ground, points.building]), h)
        local = points.building - grid.offset
        np.testing.assert_array_equal(grid.occupied_cells(local), unique_cells(grid, local))


def test_empty_point_set():
    grid = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (3, 3, 3))
    assert grid.occupied_cells(np.zeros((0, 3))).shape == (0, 3)
    assert not grid.occupancy(np.zeros((0, 3))).any()



@pytest.mark.parametrize("dtype", [np.uint16, np.int32])
def test_the_tiles_order_of_points_by_column_is_a_stable_argsort(binning, dtype):
    # The tiled run sorts every point by its column along x
    # (core.tiles._Cropper): the kernel's counting sort gives numpy's stable
    # order, runs of equal columns kept in point order, as the index type asked.
    from core import jit

    rng = np.random.default_rng(11)
    column = np.concatenate([np.repeat(np.arange(300), rng.integers(0, 40, 300)),
                             rng.integers(0, 300, 5000)]).astype(dtype)
    expected = np.argsort(column, kind="stable")
    for index in (np.int32, np.int64):
        got = jit.run("grid_kernel", "column_order", column, 300, index, size=len(column))
        if binning == "numpy":
            assert got is None
            continue
        assert got.dtype == index and np.array_equal(got, expected)


@pytest.mark.parametrize("n", [300, 70_000])  # uint16 cells, and int32 beyond
def test_the_tiles_cells_along_an_axis_are_numpys(binning, n, monkeypatch):
    # core.tiles._column: floor((x - lower) / h) clipped to 0..n-1, the same
    # with the kernel (on three threads here) as in numpy's chunks.
    from core import grid_kernel, tiles

    monkeypatch.setenv("URBANVOX_THREADS", "3")
    rng = np.random.default_rng(12)
    h, lower = 0.3, 2.6e6 + 0.17
    x = lower + rng.uniform(-5.0, n * h + 5.0, size=(20_000, 3))[:, 1]  # a strided column, some outside
    x[:50] = lower + np.arange(50) * h  # on cell boundaries
    got = tiles._column(x, lower, h, n)
    expected = np.clip(np.floor((x - lower) / h), 0, n - 1)
    assert got.dtype == (np.uint16 if n < 2**16 - 1 else np.int32)
    assert got.min() == 0 and got.max() == n - 1 and np.array_equal(got, expected)
    if binning == "compiled":
        with monkeypatch.context() as patch:
            patch.setenv("URBANVOX_JIT", "0")
            assert np.array_equal(tiles._column(x, lower, h, n), got)
        assert np.array_equal(grid_kernel.axis_cells(x, lower, h, n, np.empty(len(x), got.dtype)), got)
