"""Nodal normals of the projection (core.project) against the paper's definition."""
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
