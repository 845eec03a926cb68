"""Node and plane normals of the projection (core.project) against their definitions."""
import numpy as np

from core.grid import VoxelGrid
from core.project import node_normals
from core.quality import best_split
from core.surface import AIR_REGION, GROUND_REGION, SurfaceModel


def test_node_normals_are_the_mean_of_the_best_split_quad_normals():
    # Paper §4.2: a quad's normal from the two triangles of its best split;
    # a node's, the mean of its quads' unit normals.
    rng = np.random.default_rng(3)
    regions = np.full((5, 5, 5), AIR_REGION, dtype=np.int32)
    regions[:, :, 0] = GROUND_REGION
    regions[1:4, 1:3, 1:4] = 1
    model = SurfaceModel.from_regions(VoxelGrid(np.zeros(3), np.zeros(3), 1.0, regions.shape), regions)
    nodes = model.nodes + rng.normal(scale=0.2, size=model.nodes.shape)
    quads = model.closed_surface(1)
    triangles, _ = best_split(nodes, quads)
    p = nodes[triangles]
    tri_normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    quad_normal = tri_normal[0::2] + tri_normal[1::2]
    quad_normal /= np.linalg.norm(quad_normal, axis=1, keepdims=True)
    expected = np.zeros((len(nodes), 3))
    for q, normal in zip(quads, quad_normal):
        expected[q] += normal
    touched = np.linalg.norm(expected, axis=1) > 0
    expected[touched] /= np.linalg.norm(expected[touched], axis=1, keepdims=True)
    got = node_normals(nodes, quads, len(nodes))
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    assert touched.sum() == len(np.unique(quads)) and not got[~touched].any()


def test_least_axis_matches_lapack_on_planes_lines_and_blobs():
    from core.mls import least_axis

    rng = np.random.default_rng(11)
    for thickness in (1e-4, 0.01, 0.3, 1.0):
        for width in (1.0, 0.2, 1e-3):
            # Weighted covariances of 12 points spread (1, width, thickness), turned at random.
            x = rng.normal(size=(2000, 12, 3)) * [1.0, width, thickness]
            turn = np.linalg.qr(rng.normal(size=(2000, 3, 3)))[0]
            x = np.einsum("qkc,qdc->qkd", x, turn) + rng.normal(size=(2000, 1, 3)) * 1e3
            w = rng.random((2000, 12))
            w /= w.sum(axis=1, keepdims=True)
            d = x - np.einsum("qk,qkc->qc", w, x)[:, None, :]
            cov = np.einsum("qk,qki,qkj->qij", w, d, d)
            values, vectors = np.linalg.eigh(cov)
            normal, got = least_axis(cov)
            # The closed form loses half the digits near a double root (a line: two values near 0).
            np.testing.assert_allclose(got, values, rtol=0, atol=1e-8 * values[:, 2].max())
            np.testing.assert_allclose(np.linalg.norm(normal, axis=1), 1.0, rtol=1e-14)
            separated = values[:, 1] - values[:, 0] > 1e-3 * values[:, 2]
            tilt = np.linalg.norm(np.cross(normal, vectors[:, :, 0]), axis=1)
            assert np.all(tilt[separated] < 1e-12)
            if width >= 0.2 and thickness <= 0.3:  # planes: nearly all separated
                assert separated.sum() > 1900
    # No isolated smallest eigenvalue: a fixed vector, not NaN.
    normal, values = least_axis(np.array([np.zeros((3, 3)), 2 * np.eye(3)]))
    assert normal.tolist() == [[0, 0, 1], [0, 0, 1]] and values.round(12).tolist() == [[0, 0, 0], [2, 2, 2]]


def test_planes_fitted_once_per_data_point_are_those_fitted_each_time():
    # The projection's tries ask planes at data points, often the same ones
    # across tries: each is fitted once (mls.PlaneCache), and is the
    # plane mls_planes fits at that point alone, bit for bit.
    from core.neighbours import search_tree
    from core.mls import PLANE_POINTS, PlaneCache, mls_planes

    rng = np.random.default_rng(4)
    data = np.column_stack([rng.uniform(0, 20, 4000), rng.uniform(0, 20, 4000), rng.normal(0, 0.05, 4000)])
    data[:300, 2] = rng.uniform(0, 5, 300)  # a few points off the plane: some neighbourhoods tilt
    tree = search_tree(data)
    planes = PlaneCache(data, tree, 0.5)
    tries = [rng.integers(0, 2000, 3000), rng.integers(1000, 3000, 500), rng.integers(0, 4000, 200),
             np.zeros(0, dtype=np.intp)]
    for points in tries:
        got = planes(points)
        for one, expected in zip(got, mls_planes(data, tree, data.take(points, axis=0), 0.5, PLANE_POINTS)):
            assert np.array_equal(one, expected)
    # Each point asked for has one plane, and no other point has any.
    fitted = np.flatnonzero(planes.slot >= 0)
    assert np.array_equal(fitted, np.unique(np.concatenate(tries)))
    assert len(planes.flat) == len(fitted) == len(np.unique(planes.slot[fitted]))
