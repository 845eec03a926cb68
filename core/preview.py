"""A PNG picture of a reconstruction: oblique view, blocks coloured by height.

Written with matplotlib's Agg backend (no display needed). Faces pointing
away from the viewer are culled and the rest drawn back to front, which is
enough for a readable picture of a district without a 3-D engine.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .surface import AIR_REGION, GROUND_REGION, SurfaceModel

#: Viewer direction (from the scene towards the eye): south-west, 35 degrees up.
_AZIMUTH, _ELEVATION = np.radians(-120.0), np.radians(35.0)


def _view_axes() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    eye = np.array([np.cos(_ELEVATION) * np.cos(_AZIMUTH), np.cos(_ELEVATION) * np.sin(_AZIMUTH),
                    np.sin(_ELEVATION)])
    right = np.cross([0.0, 0.0, 1.0], eye)
    right /= np.linalg.norm(right)
    up = np.cross(eye, right)
    return eye, right, up


def _panel(ax, model: SurfaceModel, height_of_block: dict[int, float], vmax: float, title: str) -> None:
    from matplotlib import cm
    from matplotlib.collections import PolyCollection

    eye, right, up = _view_axes()
    tri = model.triangulated()
    block_tri, owner = tri.block_faces()
    ground_tri = tri.interface(GROUND_REGION, AIR_REGION)
    faces = np.concatenate([block_tri, ground_tri])
    p = tri.nodes[faces]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    length = np.maximum(np.linalg.norm(normal, axis=1), 1e-300)
    facing = normal @ eye > 0
    shade = 0.55 + 0.45 * np.clip((normal @ np.array([0.3, 0.5, 0.8])) / length, 0, 1)
    heights = np.array([height_of_block.get(int(b), 0.0) for b in owner])
    colours = np.empty((len(faces), 4))
    colours[: len(block_tri)] = cm.viridis(np.clip(heights / max(vmax, 1e-9), 0, 1))
    colours[len(block_tri):] = (0.78, 0.76, 0.70, 1.0)
    colours[:, :3] *= shade[:, None]
    depth = (p.mean(axis=1) @ eye)
    keep = np.flatnonzero(facing)
    keep = keep[np.argsort(depth[keep])]  # far first
    xy = np.stack([p[keep] @ right, p[keep] @ up], axis=-1)
    ax.add_collection(PolyCollection(xy, facecolors=colours[keep], edgecolors="none", antialiased=False))
    ax.set_xlim(xy[..., 0].min(), xy[..., 0].max())
    ax.set_ylim(xy[..., 1].min(), xy[..., 1].max())
    ax.set_aspect("equal")
    ax.set_axis_off()
    ax.set_title(title)


def write_preview(path: str | Path, panels: list[tuple[SurfaceModel, str]],
                  block_heights: dict[int, float]) -> Path:
    """Draw one or more models side by side (e.g. voxels, then the final mesh).

    Parameters
    ----------
    path : str or Path
        PNG file to write.
    panels : list of (SurfaceModel, title)
    block_heights : dict
        Height (m) of every block id, for the colours.
    """
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import cm
    from matplotlib import pyplot as plt

    vmax = max(block_heights.values(), default=1.0)
    fig, axes = plt.subplots(1, len(panels), figsize=(7 * len(panels), 6), dpi=110, squeeze=False)
    for ax, (model, title) in zip(axes[0], panels):
        _panel(ax, model, block_heights, vmax, title)
    mappable = cm.ScalarMappable(cmap="viridis", norm=matplotlib.colors.Normalize(0, vmax))
    fig.colorbar(mappable, ax=axes[0].tolist(), shrink=0.6, label="block height (m)")
    path = Path(path)
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)
    return path
