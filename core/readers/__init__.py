"""Input readers: classified LiDAR points (LAS/LAZ) and triangle meshes (STL/OBJ/PLY/OFF).

Both return world coordinates as float64 in the CRS of the input; nothing here
depends on QGIS.
"""

from .las import LabelledPoints, parse_classes, read_point_clouds
from .mesh import MESH_SUFFIXES, Triangles, base_points, edge_counts, read_triangles

__all__ = [
    "LabelledPoints",
    "parse_classes",
    "read_point_clouds",
    "MESH_SUFFIXES",
    "Triangles",
    "read_triangles",
    "base_points",
    "edge_counts",
]
