"""Tests of the synthetic city: tiles of districts and residential houses, exact truth,
a LAS file in acquisition order."""

import laspy
import numpy as np
import pytest

from core import synthetic as syn
from core import synthetic_city as city_mod
from core.synthetic import CRS_EPSG, ORIGIN


def test_city_truth_is_the_tiles_translated():
    city = city_mod.make_city(500.0, seed=0)
    assert len(city.tiles) == 4 and city.extent == (ORIGIN[0], ORIGIN[1], ORIGIN[0] + 500, ORIGIN[1] + 500)
    assert len(city.blocks) == sum(len(t.blocks) for _, _, t in city.tiles) == 55 + 3 * 100
    assert len({b.name for b in city.blocks}) == len(city.blocks)
    # the tower of the district at tile (0, 0) is unmoved; blocks of tile (1, 1) are lifted
    # by the terrain's rise so the terrain plane continues across tiles
    tower = next(b for b in city.blocks if b.name == "t0_0/tower")
    assert (tower.volume, tower.footprint_area) == pytest.approx((8640.0, 144.0))
    dx, dy, dz = city_mod.City.tile_shift(1, 1)
    assert dz == pytest.approx(syn.TERRAIN[1] * 250 + syn.TERRAIN[2] * 250)
    own = {b.name: b for b in city.tiles[3][2].blocks}
    for b in (b for b in city.blocks if b.name.startswith("t1_1/")):
        o = own[b.name.split("/", 1)[1]]
        assert b.ground_z == pytest.approx(o.ground_z + dz) and b.volume == o.volume
        assert b.centroid == pytest.approx((o.centroid[0] + dx, o.centroid[1] + dy))
        assert ORIGIN[0] + 250 < b.centroid[0] < ORIGIN[0] + 500


def test_residential_flat_houses_have_textbook_volumes():
    tile = city_mod.make_residential(3)
    parts = {}
    for p in tile._parts:
        parts.setdefault(p.block, []).append(p)
    checked = 0
    for b in tile.blocks:
        (p,) = parts[b.name] if len(parts[b.name]) == 1 else (None,)
        if p is None or p.roof != "flat":
            continue
        # a flat box on a planar terrain: footprint * height at its centre
        assert b.volume == pytest.approx(p.length * p.width * p.h)
        assert b.surface_area == pytest.approx(p.length * p.width + 2 * (p.length + p.width) * p.h)
        checked += 1
    assert checked >= 20
    # houses at least 6 m apart, so every part group is its own block
    assert len(tile.blocks) == 100


def test_city_las_counts_classes_extent_and_order(tmp_path):
    city = city_mod.make_city(500.0, seed=1)
    path = tmp_path / "city.laz"
    n = city.write_las(path, density=2.0)
    las = laspy.read(path)
    assert len(las.points) == n == las.header.point_count
    assert 2.0 * 500 * 500 * 0.95 < n < 2.0 * 500 * 500 * 1.3  # pulses + facade points
    classes = dict(zip(*np.unique(np.asarray(las.classification), return_counts=True)))
    assert set(classes) == {2, 5, 6, 7}
    assert classes[7] == 36 * len(city.tiles)
    assert classes[6] > 0.2 * n and classes[2] > 0.4 * n
    # extent corners are ground points: the header bounds are the city's extent
    assert tuple(las.header.mins[:2]) == pytest.approx(city.extent[:2])
    assert tuple(las.header.maxs[:2]) == pytest.approx(city.extent[2:])
    assert las.header.parse_crs().to_epsg() == CRS_EPSG
    assert (np.diff(np.asarray(las.gps_time)) > 0).all()  # acquisition order
