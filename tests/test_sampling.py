"""Tests of core/sampling.py: triangles -> points at most `spacing` apart (paper §2)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from core.errors import UrbanvoxError
from core.sampling import estimate_sample_count, iter_sample_triangles, lattice, refinement, sample_triangles

EPS = 1e-9


def nn_gap(points: np.ndarray) -> float:
    """Largest distance from a point to its nearest other point."""
    return float(cKDTree(points).query(points, k=2)[0][:, 1].max())


def random_triangles(count: int, seed: int = 0, scale: float = 10.0, origin=(2_600_000.0, 1_200_000.0, 400.0)):
    rng = np.random.default_rng(seed)
    return rng.random((count, 3, 3)) * scale + np.asarray(origin)


@pytest.mark.parametrize("n", [1, 2, 3, 7, 40])
def test_lattice_count_and_weights(n):
    w = lattice(n)
    assert w.shape == ((n + 1) * (n + 2) // 2, 3)
    np.testing.assert_allclose(w.sum(axis=1), 1.0)
    assert w.min() >= 0.0
    # weights are multiples of 1/n, all distinct
    assert np.allclose(w * n, np.round(w * n)) and len(np.unique(np.round(w * n), axis=0)) == len(w)


def test_single_triangle_count_vertices_edges_and_spacing():
    tri = np.array([[[0.0, 0, 0], [3, 0, 0], [0, 4, 0]]])  # longest edge 5
    spacing = 0.3
    n = int(np.ceil(5 / spacing))
    pts = sample_triangles(tri, spacing)
    assert len(pts) == (n + 1) * (n + 2) // 2 == estimate_sample_count(tri, spacing)
    # vertices included
    for corner in tri[0]:
        assert np.min(np.linalg.norm(pts - corner, axis=1)) < EPS
    # each edge carries n + 1 points
    on_x = np.abs(pts[:, 1]) < EPS
    on_y = np.abs(pts[:, 0]) < EPS
    on_hyp = np.abs(pts[:, 0] / 3 + pts[:, 1] / 4 - 1) < EPS
    assert on_x.sum() == on_y.sum() == on_hyp.sum() == n + 1
    # spacing bound: neighbouring points at most `spacing` apart, and the whole
    # triangle is covered (random points are within `spacing` of a sample)
    assert nn_gap(pts) <= spacing + EPS
    rng = np.random.default_rng(0)
    uv = rng.random((5000, 2))
    uv = np.where(uv.sum(1, keepdims=True) > 1, 1 - uv, uv)
    probe = tri[0, 0] + uv[:, :1] * (tri[0, 1] - tri[0, 0]) + uv[:, 1:] * (tri[0, 2] - tri[0, 0])
    assert cKDTree(pts).query(probe)[0].max() <= spacing
    # all points in the plane of the triangle and inside it
    assert np.all(pts[:, 2] == 0) and np.all(pts[:, :2] >= -EPS)
    assert np.all(on_hyp | (pts[:, 0] / 3 + pts[:, 1] / 4 < 1))


@pytest.mark.parametrize("spacing", [0.05, 0.1, 0.37, 1.0])
def test_spacing_bound_random_triangles(spacing):
    tris = random_triangles(20, seed=3, scale=4.0)
    for tri in tris:  # per-triangle check (a loop over test cases, not in the code under test)
        pts = sample_triangles(tri[None], spacing)
        assert nn_gap(pts) <= spacing + EPS
        longest = np.max(np.linalg.norm(tri[[1, 2, 0]] - tri, axis=1))
        n = max(1, int(np.ceil(longest / spacing)))
        assert len(pts) == (n + 1) * (n + 2) // 2


def test_exact_multiple_does_not_add_a_level():
    tri = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]])  # longest edge sqrt(2)
    assert refinement(tri, np.sqrt(2) / 4)[0] == 4
    assert refinement(tri, 10.0)[0] == 1  # tiny triangle: just its corners
    assert len(sample_triangles(tri, 10.0)) == 3


def test_big_and_small_triangles_mixed():
    small = random_triangles(500, seed=1, scale=0.05)
    big = random_triangles(3, seed=2, scale=30.0)
    corners = np.concatenate([small, big, small[:10]])
    spacing = 0.5
    n = refinement(corners, spacing)
    assert n[:500].max() == 1 and n[500:503].min() > 20
    pts = sample_triangles(corners, spacing)
    assert len(pts) == estimate_sample_count(corners, spacing) == int(((n + 1) * (n + 2) // 2).sum())
    # every small triangle contributes exactly its corners
    corner_set = cKDTree(pts)
    assert corner_set.query(small.reshape(-1, 3))[0].max() < 1e-6
    # the big triangles are sampled densely enough
    for tri in big:
        inside = sample_triangles(tri[None], spacing)
        assert corner_set.query(inside)[0].max() < 1e-6
        assert nn_gap(inside) <= spacing + EPS


def test_chunks_match_full_output():
    corners = np.concatenate([random_triangles(50, seed=4, scale=3.0), random_triangles(50, seed=5, scale=0.3)])
    full = sample_triangles(corners, 0.2)
    chunks = list(iter_sample_triangles(corners, 0.2, chunk_points=100))
    assert all(len(c) <= max(100, len(lattice(int(refinement(corners, 0.2).max())))) for c in chunks)
    streamed = np.concatenate(chunks)
    np.testing.assert_array_equal(streamed, full)
    np.testing.assert_array_equal(sample_triangles(corners, 0.2, chunk_points=7), full)


def test_large_coordinates_keep_precision():
    origin = np.array([2_680_000.0, 1_250_000.0, 500.0])
    tri = origin + np.array([[[0.0, 0, 0], [10, 0, 0], [0, 10, 10]]])
    pts = sample_triangles(tri, 0.1)
    local = sample_triangles(tri - tri[0, 0], 0.1) + tri[0, 0]
    assert np.abs(pts - local).max() < 1e-8


def test_empty_and_invalid_input():
    assert sample_triangles(np.empty((0, 3, 3)), 0.1).shape == (0, 3)
    assert estimate_sample_count(np.empty((0, 3, 3)), 0.1) == 0
    tri = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]])
    for bad in (0.0, -1.0, np.nan, np.inf):
        with pytest.raises(UrbanvoxError, match="spacing"):
            sample_triangles(tri, bad)
    with pytest.raises(UrbanvoxError, match="non-finite"):
        sample_triangles(np.full((1, 3, 3), np.nan), 0.1)
    with pytest.raises(ValueError):
        sample_triangles(np.zeros((4, 3)), 0.1)


def test_estimate_handles_huge_counts_without_overflow():
    tri = np.array([[[0.0, 0, 0], [1e7, 0, 0], [0, 1e7, 0]]])
    n = float(np.ceil(np.sqrt(2) * 1e7 / 1e-3))
    assert estimate_sample_count(tri, 1e-3) == pytest.approx((n + 1) * (n + 2) / 2, rel=1e-9)


def test_real_zurich_sampling_at_1m(shared_data: Path):
    path = shared_data / "cityjson" / "zurich_subset_lod2_buildings.stl"
    if not path.exists():
        pytest.skip("real test data cityjson/zurich_subset_lod2_buildings.stl not available")
    from core.readers.mesh import read_triangles

    corners = read_triangles(path).corners()
    voxel = 1.0
    spacing = 0.1 * voxel
    expected = estimate_sample_count(corners, spacing)
    start = time.perf_counter()
    count = sum(len(chunk) for chunk in iter_sample_triangles(corners, spacing))
    streamed_s = time.perf_counter() - start
    start = time.perf_counter()
    pts = sample_triangles(corners, spacing)
    full_s = time.perf_counter() - start
    print(
        f"\nzurich sampling at {voxel} m voxel (spacing {spacing} m): {len(corners)} triangles -> "
        f"{len(pts)} points ({pts.nbytes / 1e6:.0f} MB), streamed {streamed_s:.2f} s, array {full_s:.2f} s"
    )
    assert count == expected == len(pts)
    lo, hi = corners.reshape(-1, 3).min(axis=0), corners.reshape(-1, 3).max(axis=0)
    assert np.all(pts.min(axis=0) >= lo - 1e-6) and np.all(pts.max(axis=0) <= hi + 1e-6)


def test_cell_means_match_np_unique_with_runs_and_without():
    # _cell_means sorts only the keys of runs of points in one cell: the same
    # cells, counts and sums as np.unique's inverse and bincount, bit for bit.
    from core.sampling import _cell_means

    rng = np.random.default_rng(9)
    cell, low = 0.5, np.array([-2, -2, -2])
    for trial in range(6):
        points = rng.random((int(rng.integers(1, 5000)), 3)) * 4
        if trial % 2:
            points = np.sort(points, axis=0)  # long runs in one cell
        ijk = np.floor(points / cell).astype(np.int64) - low
        key = ijk[:, 0] | (ijk[:, 1] << 21) | (ijk[:, 2] << 42)
        unique, inverse = np.unique(key, return_inverse=True)
        sums = np.column_stack([np.bincount(inverse, weights=points[:, c]) for c in range(3)])
        got_unique, got_sums, got_counts = _cell_means(points, cell, low, len(points))
        assert np.array_equal(got_unique, unique)
        assert np.array_equal(got_counts, np.bincount(inverse).astype(float))
        assert np.array_equal(got_sums, sums)


def test_thinned_sampling_reports_the_share_of_samples_made():
    from core.sampling import sample_thinned

    rng = np.random.default_rng(5)
    corners = rng.random((200, 3, 3)) * 10.0
    total = estimate_sample_count(corners, 0.2)
    seen = []
    points = sample_thinned(corners, 0.2, 0.5, chunk_points=total // 7, progress=lambda f, m: seen.append(f))
    fractions = np.array(seen)
    assert len(fractions) >= 7 and np.all(np.diff(fractions) > 0) and fractions[-1] == pytest.approx(1.0)
    assert np.array_equal(points, sample_thinned(corners, 0.2, 0.5, chunk_points=total // 7))


def test_a_triangle_larger_than_a_chunk_is_sampled_in_bands_of_its_rows():
    """A ground of one triangle a kilometre wide at 0.1 m spacing is 10^8
    points: its lattice comes in bands of rows no larger than a chunk, the
    same points in the same order as whole."""
    from core.sampling import lattice_rows

    corners = np.concatenate([random_triangles(3, seed=8, scale=40.0), random_triangles(20, seed=9, scale=2.0)])
    whole = list(iter_sample_triangles(corners, 0.5, chunk_points=10**9))
    assert max(len(c) for c in whole) > 2000  # the three large triangles' lattices
    chunks = list(iter_sample_triangles(corners, 0.5, chunk_points=400))
    assert max(len(c) for c in chunks) <= 400
    np.testing.assert_array_equal(np.concatenate(chunks), np.concatenate(whole))
    for n in (1, 4, 13):
        np.testing.assert_array_equal(np.concatenate([lattice_rows(n, a, a + 1) for a in range(n + 1)]), lattice(n))


def test_a_voxel_far_too_small_for_a_mesh_is_refused_before_sampling(district):
    """A 1 mm voxel on the district's mesh: hours of samples and terabytes;
    refused at once with the voxel size that fits."""
    from core.pipeline import ReconstructionParams, reconstruct_mesh

    start = time.perf_counter()
    with pytest.raises(UrbanvoxError, match=r"Sampling the mesh.* voxel size of at least (\d|\.)+"):
        reconstruct_mesh(district.stl, crs=district.crs, params=ReconstructionParams(voxel_size=0.001))
    assert time.perf_counter() - start < 30
