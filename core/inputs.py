"""The run's inputs, checked before the method starts: the user's parameters
(:class:`ReconstructionParams`) and the points handed to it
(:func:`checked_points`: rows of (x, y, z), finite, inside the extent, with
ground). A value that would make a run go wrong, or a run that cannot find
what it needs, stops here with a message that says what to change.
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from .errors import UrbanvoxError
from .vectors import all_finite, finite_rows


@dataclass
class ReconstructionParams:
    """User parameters; lengths in metres, converted to CRS units internally.

    Attributes
    ----------
    voxel_size : float
        Edge of a voxel (m).
    min_height, min_footprint, min_volume : float
        Blocks below any of these (m, m², m³) are dropped (paper §3.2).
    support : float
        Boundary voxel elimination distance, in voxel sizes (paper §3.4: 0.6).
    max_roof_hole_area : float
        Largest roof hole of a point cloud that is filled (m², see
        :func:`core.classify.roof_hole_columns`).
    smoothing_iterations : int
        Vertex-only Catmull-Clark passes (paper §4.1: 3).
    project : bool
        Project the smoothed nodes onto the data (paper §4.2).
    quality_threshold : float
        Smallest face quality (normalised inradius / longest edge, 1 for an
        equilateral triangle, 0.72 for a voxel face) a smoothing or
        projection move may leave.
    max_projection_angle : float
        Largest angle (degrees) between a node normal and the data plane it
        is projected on.
    extent : tuple of float, optional
        ``(xmin, ymin, xmax, ymax)`` in CRS units: the domain, data outside
        it is dropped and blocks crossing it are closed on its sides.
        Default: the extent of the data.
    max_memory : int, optional
        Bytes the voxel grid may use; default: the memory available.
    """

    voxel_size: float = 1.0
    min_height: float = 2.5
    min_footprint: float = 10.0
    min_volume: float = 20.0
    support: float = 0.6
    max_roof_hole_area: float = 100.0
    smoothing_iterations: int = 3
    project: bool = True
    quality_threshold: float = 0.2
    max_projection_angle: float = 45.0
    extent: tuple[float, float, float, float] | None = None
    max_memory: int | None = None

    def __post_init__(self) -> None:
        """Refuse values that are no number or out of range (a ``voxel_size`` of
        zero has its own message at the run), rather than runs that go wrong."""
        for name in ("voxel_size", "min_height", "min_footprint", "min_volume", "support", "max_roof_hole_area",
                     "quality_threshold", "max_projection_angle"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real):
                raise UrbanvoxError(f"The parameter {name} must be a number (got {value!r}).")
        for name in ("min_height", "min_footprint", "min_volume", "support", "max_roof_hole_area"):
            if not 0 <= getattr(self, name) < math.inf:
                raise UrbanvoxError(f"The parameter {name} must be a number of 0 or more (got {getattr(self, name)}).")
        if isinstance(self.smoothing_iterations, bool) or not isinstance(self.smoothing_iterations, numbers.Integral) \
                or self.smoothing_iterations < 0:
            raise UrbanvoxError(f"The smoothing passes must be a whole number of 0 or more "
                                f"(got {self.smoothing_iterations!r}).")
        if not 0 <= self.quality_threshold < 1:
            raise UrbanvoxError(f"The minimum face quality must be at least 0 and below 1 "
                                f"(got {self.quality_threshold}).")
        if not 0 < self.max_projection_angle <= 90:
            raise UrbanvoxError(f"The largest projection angle must be above 0 and at most 90 degrees "
                                f"(got {self.max_projection_angle}).")


def checked_points(ground: np.ndarray, building: np.ndarray, extent, airborne: bool,
                   warnings: list) -> tuple[np.ndarray, np.ndarray]:
    """The ground and building points a run may use: finite rows of (x, y,
    z) (others dropped with a warning), those inside ``extent`` if given;
    an error where no ground is left, saying why (the extent beside the
    data or under a roof, the ground classes, the mesh's ground).
    """
    ground = _finite(ground, "ground", warnings)
    building = _finite(building, "building", warnings)
    if extent is not None:
        unclipped = ground, building
        ground = _inside(ground, extent)
        building = _inside(building, extent)
        if len(unclipped[0]) and len(ground) == 0:
            raise UrbanvoxError(
                f"No ground point lies inside the extent {_extent_text(extent)} (EXTENT); the data cover "
                f"{_extent_text(_extent_of(*unclipped))}"
                + (f", and the extent holds {len(building)} building points only: it lies under a roof."
                   if len(building) else ": the extent misses them (in another CRS?).")
                + " Give an extent over the data, with ground around the buildings.")
    if len(ground) == 0:
        raise UrbanvoxError("No ground point: check the ground classes (GROUND_CLASSES)." if airborne else
                            "No ground: the mesh has no ground faces and no base points; give a ground mesh.")
    return ground, building


def _inside(points: np.ndarray, extent) -> np.ndarray:
    xmin, ymin, xmax, ymax = extent
    if not (xmax > xmin and ymax > ymin):
        raise UrbanvoxError(f"The extent {tuple(extent)} is empty: give xmin < xmax and ymin < ymax.")
    keep = ((points[:, 0] >= xmin) & (points[:, 0] <= xmax)
            & (points[:, 1] >= ymin) & (points[:, 1] <= ymax))
    return points.compress(keep, axis=0)


def _extent_of(*parts: np.ndarray) -> tuple[float, float, float, float]:
    """(xmin, ymin, xmax, ymax) of the points of every part (some may be empty)."""
    present = [p for p in parts if len(p)]
    low = np.min([p[:, :2].min(axis=0) for p in present], axis=0)
    high = np.max([p[:, :2].max(axis=0) for p in present], axis=0)
    return float(low[0]), float(low[1]), float(high[0]), float(high[1])


def _extent_text(extent) -> str:
    xmin, ymin, xmax, ymax = (float(v) for v in extent)
    return f"x {xmin:.2f} to {xmax:.2f}, y {ymin:.2f} to {ymax:.2f}"


def _finite(points: np.ndarray, what: str, warnings: list[str]) -> np.ndarray:
    points = np.asarray(points, dtype=np.float64)
    if points.size == 0:
        return points.reshape(0, 3)
    if points.ndim != 2 or points.shape[1] != 3:
        raise UrbanvoxError(f"The {what} points must be an array of (x, y, z) rows, got shape {points.shape}.")
    if all_finite(points):  # the usual case, in a sixth of the time of the rows' mask
        return points
    ok = finite_rows(points)
    if not ok.all():
        warnings.append(f"Ignored {int((~ok).sum())} {what} points with non-finite coordinates.")
        points = points.compress(ok, axis=0)
    return points
