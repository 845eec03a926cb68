"""Coordinate reference system of the input: choose it and check that voxels make sense in it.

Voxels are cubes, so the horizontal coordinates must be a projected (or local
engineering) system with a linear unit; latitude/longitude in degrees cannot be
voxelised. The CRS comes from the file header, or from the user's CRS parameter
which always wins (headers are often missing or wrong: AHN3 tiles carry none).

Example
-------
>>> crs = resolve_crs(None, "EPSG:28992", "tile.laz")
>>> crs.to_epsg(), metres_per_unit(crs)
(28992, 1.0)
>>> round(metres_per_unit(resolve_crs(None, "EPSG:2263", "nyc.las")), 7)  # US survey foot
0.3048006
"""

from __future__ import annotations

from typing import Optional

import pyproj
from pyproj.exceptions import CRSError

from .errors import UrbanvoxError

__all__ = ["resolve_crs", "metres_per_unit", "vertical_metres_per_unit", "horizontal_crs", "describe_crs"]


def horizontal_crs(crs: pyproj.CRS) -> pyproj.CRS:
    """Return the horizontal part of ``crs``.

    A compound CRS (e.g. ``EPSG:2154+5720``, Lambert-93 + NGF-IGN69 heights) is
    reduced to its first sub-CRS; a bound CRS (a PROJ string with ``+towgs84``)
    to its source CRS. Other CRSs are returned unchanged.

    Example
    -------
    >>> horizontal_crs(pyproj.CRS("EPSG:2154+5720")).to_epsg()
    2154
    """
    # Bound CRSs only carry a datum shift; the coordinates are in the source CRS.
    while getattr(crs, "is_bound", False) and crs.source_crs is not None:
        crs = crs.source_crs
    if crs.is_compound and crs.sub_crs_list:
        return horizontal_crs(crs.sub_crs_list[0])
    return crs


def describe_crs(crs: pyproj.CRS) -> str:
    """Short human-readable name for messages: ``"RD New (EPSG:28992)"``.

    Example
    -------
    >>> describe_crs(pyproj.CRS("EPSG:4326"))
    'WGS 84 (EPSG:4326)'
    """
    try:
        # min_confidence keeps WKT read from LAS headers recognisable without
        # a slow exhaustive database search.
        code = crs.to_epsg(min_confidence=70)
    except CRSError:  # pragma: no cover - defensive, pyproj rarely raises here
        code = None
    name = crs.name or "unnamed CRS"
    return f"{name} (EPSG:{code})" if code else name


def _parse_override(override: str, source: str) -> pyproj.CRS:
    text = override.strip()
    try:
        crs = pyproj.CRS.from_user_input(text)
    except CRSError as exc:
        raise UrbanvoxError(
            f"The CRS parameter {text!r} given for {source} is not a valid coordinate reference "
            f"system ({exc}). Give an authority code such as EPSG:28992, a WKT string or a PROJ string."
        ) from exc
    # A bare name is looked up in PROJ's database, closest match first: "foo"
    # would be Amersfoort, "bar" Barbados 1938. Only the name itself counts.
    is_name = not any(mark in text for mark in (":", "+", "[", "{", "=")) and not text.isdigit()
    if is_name and " ".join(crs.name.lower().split()) != " ".join(text.lower().split()):
        raise UrbanvoxError(
            f"No coordinate reference system is named {text!r} (the nearest name is {crs.name!r}, "
            f"{crs.to_string()}). Give an authority code such as EPSG:28992, a WKT string or a PROJ string."
        )
    return crs


def _linear_axis_factor(crs: pyproj.CRS) -> Optional[float]:
    """Metres per unit of the first axis, or None if the axes are not linear."""
    axes = crs.axis_info or (crs.coordinate_system.axis_list if crs.coordinate_system else [])
    if not axes:
        return None
    axis = axes[0]
    # Angular units (degree, grad, radian) are recognisable by their name; their
    # conversion factor is to radians, not metres.
    name = (axis.unit_name or "").lower()
    if any(word in name for word in ("degree", "grad", "radian", "arc-second", "arc-minute")):
        return None
    factor = axis.unit_conversion_factor
    return float(factor) if factor and factor > 0 else None


def _check_projected(crs: pyproj.CRS, source: str, origin: str) -> None:
    horiz = horizontal_crs(crs)
    if horiz.is_geographic:
        raise UrbanvoxError(
            f"The CRS of {source} ({origin}) is geographic ({describe_crs(horiz)}, degrees); voxels need a "
            "projected CRS in metres: reproject the data (e.g. with PDAL or QGIS) or, if the header is "
            "wrong, pass the right projected CRS in the CRS parameter."
        )
    if horiz.is_geocentric:
        raise UrbanvoxError(
            f"The CRS of {source} ({origin}) is geocentric ({describe_crs(horiz)}, X/Y/Z from the Earth's "
            "centre) so Z is not height; reproject the data to a projected CRS (e.g. with PDAL) or pass "
            "the right projected CRS in the CRS parameter."
        )
    if _linear_axis_factor(horiz) is None:
        raise UrbanvoxError(
            f"The CRS of {source} ({origin}, {describe_crs(horiz)}) has no linear unit, so voxel sizes "
            "cannot be expressed in it; pass a projected CRS in metres or feet in the CRS parameter."
        )


def resolve_crs(header_crs: Optional[pyproj.CRS], override: Optional[str], source: str) -> pyproj.CRS:
    """Choose the CRS of one input and check that it can be voxelised.

    Parameters
    ----------
    header_crs : pyproj.CRS or None
        CRS read from the file header (None when the header has none).
    override : str or None
        The user's CRS parameter: anything ``pyproj.CRS.from_user_input`` accepts
        ("EPSG:28992", WKT, PROJ string). Wins over ``header_crs``. Empty or
        blank strings count as "not given".
    source : str
        File name used in error messages.

    Returns
    -------
    pyproj.CRS
        The chosen CRS (compound CRSs are returned whole; only their horizontal
        part is checked).

    Raises
    ------
    UrbanvoxError
        No CRS at all, an invalid override, or a geographic / geocentric / unitless CRS.

    Example
    -------
    >>> resolve_crs(pyproj.CRS("EPSG:2154"), None, "a.laz").to_epsg()
    2154
    >>> resolve_crs(pyproj.CRS("EPSG:2154"), "EPSG:28992", "a.laz").to_epsg()
    28992
    >>> try:
    ...     resolve_crs(None, None, "a.laz")
    ... except UrbanvoxError as exc:
    ...     print(exc)
    a.laz has no CRS in its header; set the CRS parameter (e.g. EPSG:28992 for the Netherlands, EPSG:2154 for France).
    """
    if override is not None and str(override).strip():
        crs = _parse_override(str(override), source)
        origin = "from the CRS parameter"
    elif header_crs is not None:
        crs = header_crs
        origin = "from its header"
    else:
        raise UrbanvoxError(
            f"{source} has no CRS in its header; set the CRS parameter "
            "(e.g. EPSG:28992 for the Netherlands, EPSG:2154 for France)."
        )
    _check_projected(crs, source, origin)
    return crs


def metres_per_unit(crs: pyproj.CRS) -> float:
    """Length in metres of one horizontal coordinate unit of ``crs``.

    1.0 for metre CRSs, 0.3048 for the international foot, 0.3048006096 for the
    US survey foot. The pipeline divides metre parameters (voxel size, ...) by
    this value to express them in CRS units.

    Raises
    ------
    UrbanvoxError
        If the horizontal axes are not linear (geographic CRS).

    Example
    -------
    >>> metres_per_unit(pyproj.CRS("EPSG:7415"))  # RD New + NAP height
    1.0
    >>> metres_per_unit(pyproj.CRS("+proj=tmerc +units=ft"))
    0.3048
    """
    factor = _linear_axis_factor(horizontal_crs(crs))
    if factor is None:
        raise UrbanvoxError(
            f"The CRS {describe_crs(crs)} has no linear horizontal unit; use a projected CRS in metres or feet."
        )
    return factor


def vertical_metres_per_unit(crs: pyproj.CRS) -> Optional[float]:
    """Metres per unit of the vertical axis when ``crs`` declares one, else None.

    LAS heights are usually in the horizontal unit; a compound CRS may say
    otherwise (e.g. UTM metres + NAVD88 US feet), which would make voxels
    non-cubic. The pipeline can compare this with :func:`metres_per_unit`.

    Example
    -------
    >>> vertical_metres_per_unit(pyproj.CRS("EPSG:2154+5720"))
    1.0
    >>> vertical_metres_per_unit(pyproj.CRS("EPSG:2154")) is None
    True
    """
    while getattr(crs, "is_bound", False) and crs.source_crs is not None:
        crs = crs.source_crs
    if crs.is_compound and len(crs.sub_crs_list) > 1:
        vertical = crs.sub_crs_list[1]
        axes = vertical.axis_info
        if axes and axes[0].unit_conversion_factor:
            return float(axes[0].unit_conversion_factor)
        return None
    axes = crs.axis_info
    if len(axes) >= 3 and axes[2].unit_conversion_factor and not crs.is_geographic:
        return float(axes[2].unit_conversion_factor)
    return None
