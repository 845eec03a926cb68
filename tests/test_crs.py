"""Tests of core/crs.py: the CRS of the data from a file's header and the CRS parameter, and its units."""
import pyproj
import pytest

from core.crs import metres_per_unit, resolve_crs, vertical_metres_per_unit
from core.errors import UrbanvoxError


def test_resolve_crs_override_wins_and_header_used():
    assert resolve_crs(pyproj.CRS("EPSG:2154"), None, "a.laz").to_epsg() == 2154
    assert resolve_crs(pyproj.CRS("EPSG:2154"), "EPSG:28992", "a.laz").to_epsg() == 28992
    with pytest.raises(UrbanvoxError, match="no CRS"):
        resolve_crs(None, "  ", "a.laz")
    wkt = pyproj.CRS("EPSG:28992").to_wkt()
    assert resolve_crs(None, wkt, "a.laz").to_epsg() == 28992
    assert resolve_crs(None, "+proj=utm +zone=31 +datum=WGS84 +units=m", "a.laz").is_projected


def test_resolve_crs_missing_names_file_and_parameter():
    with pytest.raises(UrbanvoxError) as err:
        resolve_crs(None, None, "/data/tile_17.laz")
    msg = str(err.value)
    assert "/data/tile_17.laz" in msg and "no CRS" in msg and "CRS parameter" in msg and "EPSG:28992" in msg


@pytest.mark.parametrize("code", ["EPSG:4326", "EPSG:4979", "EPSG:4326+5773"])
def test_resolve_crs_geographic_rejected(code):
    with pytest.raises(UrbanvoxError, match=r"geographic .*degrees.*projected CRS in metres"):
        resolve_crs(pyproj.CRS(code), None, "a.laz")
    with pytest.raises(UrbanvoxError, match="geographic"):
        resolve_crs(None, code, "a.laz")


def test_resolve_crs_geocentric_and_invalid_rejected():
    with pytest.raises(UrbanvoxError, match="geocentric"):
        resolve_crs(pyproj.CRS("EPSG:4978"), None, "a.laz")
    with pytest.raises(UrbanvoxError, match="not a valid coordinate reference system"):
        resolve_crs(None, "EPSG:999999", "a.laz")
    with pytest.raises(UrbanvoxError, match="EPSG:28992"):
        resolve_crs(None, "bogus", "a.laz")


def test_a_crs_name_must_be_the_name_not_its_nearest_match():
    """PROJ 9.1 (Debian 12) takes "foo" for Amersfoort and "bar" for Barbados 1938: refused,
    naming the match (PROJ 9.5 finds no such name: refused as invalid); a CRS's own name (any
    case and spacing) is taken."""
    for word in ("foo", "bar"):
        with pytest.raises(UrbanvoxError, match="No coordinate reference system is named|not a valid coordinate"):
            resolve_crs(None, word, "a.laz")
    assert resolve_crs(None, "amersfoort /  RD New", "a.laz").to_epsg() == 28992
    assert resolve_crs(None, "epsg:2154", "a.laz").to_epsg() == 2154
    assert resolve_crs(None, "28992", "a.laz").to_epsg() == 28992


def test_resolve_crs_compound_uses_horizontal_part():
    crs = resolve_crs(None, "EPSG:2154+5720", "a.laz")
    assert crs.is_compound
    assert metres_per_unit(crs) == 1.0
    assert vertical_metres_per_unit(crs) == 1.0
    assert vertical_metres_per_unit(pyproj.CRS("EPSG:2154")) is None


def test_metres_per_unit():
    assert metres_per_unit(pyproj.CRS("EPSG:28992")) == 1.0
    assert metres_per_unit(pyproj.CRS("+proj=tmerc +units=ft")) == pytest.approx(0.3048)
    assert metres_per_unit(pyproj.CRS("EPSG:2263")) == pytest.approx(1200 / 3937)  # US survey foot
    with pytest.raises(UrbanvoxError):
        metres_per_unit(pyproj.CRS("EPSG:4326"))
