"""The GIS layers' geometries (core.reconstruction): each block's surface is
closed and holds the block's mesh volume, the ground's tiles cover the
terrain once, and the layers are the same whether or not the mesh files'
triangulation was made first."""
import dataclasses

import numpy as np
import pytest
import shapely

from core.pipeline import ReconstructionParams, reconstruct_point_cloud
from core.surface import AIR_REGION, GROUND_REGION
from core.topology import check_surface


@pytest.fixture(scope="module")
def result(district):
    params = ReconstructionParams(voxel_size=2.0, extent=district.district.extent)
    return reconstruct_point_cloud(district.laz, params=params)


def fresh(result):
    """The same reconstruction without its triangulated mesh (made by a mesh file)."""
    return dataclasses.replace(result)


def triangles_of(wkb, offset):
    """The triangles of a MultiPolygonZ as node ids (coordinates numbered) and
    their corners, less ``offset``."""
    parts = shapely.get_parts(shapely.from_wkb(wkb))
    rings = np.stack([shapely.get_coordinates(shapely.get_exterior_ring(p), include_z=True) for p in parts])
    assert rings.shape[1:] == (4, 3) and np.array_equal(rings[:, 0], rings[:, 3])  # closed triangles
    corners = rings[:, :3] - offset
    _, ids = np.unique(corners.reshape(-1, 3), axis=0, return_inverse=True)
    return ids.reshape(-1, 3), corners


def test_block_surfaces_are_closed_and_hold_the_mesh_volume(result):
    layer = list(fresh(result).block_surface_wkb())
    assert len(layer) == len(result.blocks) > 5
    for index, wkb in enumerate(layer):
        faces, corners = triangles_of(wkb, result.grid.offset)
        assert check_surface(faces).ok
        volume = np.einsum("ij,ij->i", corners[:, 0], np.cross(corners[:, 1], corners[:, 2])).sum() / 6
        block = result.blocks.block_id[index]
        assert volume == pytest.approx(result.measures.volume[block - 1], rel=1e-9)
        assert 0.5 < volume / result.blocks.volume[index] < 1.5  # the voxels smoothed, at 2 m: coarse


def test_ground_tiles_hold_every_terrain_triangle_once(result):
    tiles = list(fresh(result).ground_surface_wkb())
    assert len(tiles) > 1
    got = np.concatenate([triangles_of(wkb, 0.0)[1] for wkb in tiles]).reshape(-1, 9)
    triangles = result.mesh_triangles
    terrain = result.grid.to_world(triangles.nodes)[triangles.interface(GROUND_REGION, AIR_REGION)].reshape(-1, 9)
    # The same triangles, corners in the same order, up to the tiles' order.
    assert np.array_equal(got[np.lexsort(got.T[::-1])], terrain[np.lexsort(terrain.T[::-1])])


def test_layers_do_not_depend_on_the_mesh_files_triangulation(result):
    """Made on their own faces, or taken from the mesh files' triangles: the same bytes."""
    alone = fresh(result)
    assert alone._triangles is None
    blocks, ground = list(alone.block_surface_wkb()), list(alone.ground_surface_wkb())
    assert alone._triangles is None  # the layers did not triangulate the whole model
    made = fresh(result)
    made.mesh_triangles
    assert list(made.block_surface_wkb()) == blocks and list(made.ground_surface_wkb()) == ground


def test_the_measures_splits_are_the_layers_and_mesh_files(result, monkeypatch):
    """The block faces' splits the measures chose (carried as block_diagonal)
    give the layers and the mesh files' triangles of a search of their own;
    the blocks layer then searches none."""
    from core import quality
    from core.measure import block_face_split

    assert np.array_equal(result.block_diagonal, block_face_split(result.mesh, result.mesh.nodes)[0])
    own = dataclasses.replace(result, block_diagonal=None)
    blocks, ground, triangles = list(own.block_surface_wkb()), list(own.ground_surface_wkb()), own.mesh_triangles
    searched = []
    real = quality.best_diagonal
    monkeypatch.setattr(quality, "best_diagonal",
                        lambda nodes, quads: searched.append(len(quads)) or real(nodes, quads))
    carried = fresh(result)
    assert list(carried.block_surface_wkb()) == blocks and searched == []
    assert list(carried.ground_surface_wkb()) == ground
    carried = fresh(result)
    assert np.array_equal(carried.mesh_triangles.quads, triangles.quads)
    n_block = int(((result.mesh.regions > 0).any(axis=1)).sum())
    assert searched[-1] == len(result.mesh.quads) - n_block > 0  # only the faces of no block
