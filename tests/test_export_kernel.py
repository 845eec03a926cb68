"""The compiled connected parts of the gmsh export (core.export_kernel)
against scipy's labelling (core.export): the same parts, numbered alike."""
import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from core import export


@pytest.fixture
def kernel(compiled):
    return compiled("export_kernel")


@pytest.mark.parametrize("seed", range(8))
def test_parts_are_scipys(kernel, seed):
    """Random links between items and vertices, sparse (many parts, vertices
    on no link) to dense (one part)."""
    rng = np.random.default_rng(seed)
    n_items, n_vertices = int(rng.integers(1, 3000)), int(rng.integers(1, 3000))
    links = int(rng.integers(0, 3 * (n_items + n_vertices)))
    item = rng.integers(0, n_items, links)
    vertex = (n_items + rng.integers(0, n_vertices, links)).astype(np.int32 if seed % 2 else np.int64)
    size = n_items + n_vertices
    graph = coo_matrix((np.ones(links), (item, vertex)), shape=(size, size)).tocsr()
    expected = connected_components(graph, directed=False)[1]
    got = kernel.link_parts(item, vertex, size)
    assert got.dtype == expected.dtype and np.array_equal(got, expected)


def test_linked_parts_of_faces_are_numpys(with_numpy, kernel):
    """Triangles of a shaken lattice in a few groups: the parts, pairs and
    pairs' parts the export's numpy code finds."""
    rng = np.random.default_rng(2)
    tri = rng.integers(0, 4000, (6000, 3))
    group = np.repeat(rng.integers(0, 5, len(tri)), 3)
    item = np.repeat(np.arange(len(tri)), 3)
    expected = with_numpy(export._linked_parts, item, group, tri.ravel(), len(tri), 4000)
    got = export._linked_parts(item, group, tri.ravel(), len(tri), 4000)
    assert len(np.unique(expected[0])) > 1
    for a, b in zip(got, expected):
        assert np.array_equal(a, b)
