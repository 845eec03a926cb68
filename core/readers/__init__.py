"""Input readers: classified LiDAR points (LAS/LAZ), triangle meshes (STL/OBJ/PLY/OFF) and
CityJSON city models (their buildings and terrain, triangulated).

Both return world coordinates as float64 in the CRS of the input; nothing here
depends on QGIS.
"""

from .las import LabelledPoints, parse_classes, read_point_clouds
from .cityjson import CityModel, is_cityjson, read_cityjson
from .mesh import MESH_SUFFIXES, Triangles, base_points, clean_triangles, edge_counts, read_triangles

__all__ = [
    "LabelledPoints",
    "parse_classes",
    "read_point_clouds",
    "MESH_SUFFIXES",
    "Triangles",
    "read_triangles",
    "clean_triangles",
    "CityModel",
    "is_cityjson",
    "read_cityjson",
    "base_points",
    "edge_counts",
]
