"""A PNG picture of a reconstruction: oblique view, blocks coloured by height.

Faces pointing away from the viewer are culled and the rest rasterised with
a depth buffer: each triangle is sampled in proportion to its area on the
picture (three samples per pixel; its centroid when it is smaller than a
pixel), and every pixel takes the colour of its nearest sample. A city has
millions of faces about a pixel large: drawing them as polygons with
matplotlib took longer than the reconstruction. The panels are
laid out and written on a matplotlib figure of their own, on its Agg canvas
(no display needed, and the host's pyplot untouched).
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable

import numpy as np

from . import jit
from .heap import reusing_freed_memory
from .progress import CancelCheck, check_cancel
from .surface import AIR_REGION, GROUND_REGION, SurfaceModel, rank_in
from .topology import run_starts
from .vectors import minus

#: Viewer direction (from the scene towards the eye): south-west, 35 degrees up.
_AZIMUTH, _ELEVATION = np.radians(-120.0), np.radians(35.0)


def _view_axes() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    eye = np.array([np.cos(_ELEVATION) * np.cos(_AZIMUTH), np.cos(_ELEVATION) * np.sin(_AZIMUTH),
                    np.sin(_ELEVATION)])
    right = np.cross([0.0, 0.0, 1.0], eye)
    right /= np.linalg.norm(right)
    up = np.cross(eye, right)
    return eye, right, up


#: Width of a panel's picture in pixels, and samples per pixel of a triangle's area.
_PIXELS, _SAMPLES_PER_PIXEL = 770, 3.0
#: Steps of the R2 low-discrepancy sequence (the samples inside a triangle).
_R2_U, _R2_V = 0.7548776662466927, 0.5698402909980532


def _panel(ax, model: SurfaceModel, height_of_block: dict[int, float], vmax: float, title: str) -> None:
    from matplotlib import cm

    eye, right, up = _view_axes()
    block_faces, owner = model.block_faces()
    block_corners = _triangle_corners(block_faces)
    ground_corners = _triangle_corners(model.interface(GROUND_REGION, AIR_REGION))
    n_block = sum(len(part) for part in block_corners[0])  # the block triangles come first
    owner = np.concatenate([owner] * len(block_corners[0]))
    # View coordinates (across, up, and depth towards the eye) of the nodes,
    # once: a rotation, so a face's normal there is its normal rotated, and
    # its depth component says whether it is turned to the viewer.
    rotation = np.column_stack([right, up, eye])
    view_nodes = model.nodes @ rotation
    # Each corner's coordinates gathered from contiguous columns.
    x, y, z = (np.ascontiguousarray(view_nodes[:, axis]) for axis in range(3))
    # Each corner's node column made once from the faces' columns (no (T, 3) table of triangles).
    a, b, c = (np.concatenate(block_corners[k] + ground_corners[k]) for k in range(3))
    del block_corners, ground_corners
    values = np.array(list(height_of_block.values()), dtype=np.float64)
    light = np.array([0.3, 0.5, 0.8]) @ rotation

    def colours_of(face: np.ndarray) -> np.ndarray:
        """RGBA of the faces ``face`` (the pixels' nearest: a few hundred
        thousand of a city's millions), by height, lit by their normal (its
        depth component: the face's turn towards the eye)."""
        corner = [[column.take(point.take(face)) for column in (x, y, z)] for point in (a, b, c)]
        e1, e2 = minus(corner[1], corner[0]), minus(corner[2], corner[0])
        towards_eye = e1[0] * e2[1] - e1[1] * e2[0]
        normal = np.column_stack([e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], towards_eye])
        on_block = face < n_block
        block = owner[face[on_block]]
        rank = rank_in(block, list(height_of_block))
        heights = np.where(rank >= 0, values[rank], 0.0) if len(values) else np.zeros(len(block))
        colours = np.empty((len(face), 4))
        colours[on_block] = cm.viridis(np.clip(heights / max(vmax, 1e-9), 0, 1))
        colours[~on_block] = (0.78, 0.76, 0.70, 1.0)
        length = np.maximum(np.linalg.norm(normal, axis=1), 1e-300)
        colours[:, :3] *= (0.55 + 0.45 * np.clip((normal @ light) / length, 0, 1))[:, None]
        return colours

    image, extent = _rasterised((x, y, z), (a, b, c), colours_of)
    ax.imshow(image, origin="lower", extent=extent, interpolation="nearest")
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_aspect("equal")
    ax.set_axis_off()
    ax.set_title(title)


def _triangle_corners(faces: np.ndarray) -> list[list[np.ndarray]]:
    """The node columns of the three corners of the triangles of ``faces``,
    each in parts to concatenate: quads split along their fixed diagonal
    0-2 (every first triangle, then every second), triangles as they are.
    Any split draws the same picture; the meshes' best split costs a
    quality evaluation per quad.

    Examples
    --------
    >>> corners = _triangle_corners(np.array([[0, 1, 2, 3], [4, 5, 6, 7]]))
    >>> [np.concatenate(parts).tolist() for parts in corners]
    [[0, 4, 0, 4], [1, 5, 2, 6], [2, 6, 3, 7]]
    """
    if faces.shape[1] == 3:
        return [[faces[:, k]] for k in range(3)]
    return [[faces[:, 0], faces[:, 0]], [faces[:, 1], faces[:, 2]], [faces[:, 2], faces[:, 3]]]


def _rasterised(columns: tuple[np.ndarray, np.ndarray, np.ndarray], faces: tuple[np.ndarray, np.ndarray, np.ndarray],
                colours_of: Callable[[np.ndarray], np.ndarray]) -> tuple[np.ndarray, tuple[float, float, float, float]]:
    """RGBA picture of the triangles turned to the viewer, and its extent
    (x0, x1, y0, y1). ``columns`` are the nodes' x, y and depth (larger is
    nearer) in view coordinates, ``faces`` the triangles' three corners;
    ``colours_of(shown)`` gives the RGBA of the triangles ``shown`` (those
    of the picture, ascending).

    Examples
    --------
    Two squares' worth of triangles, the nearer red one over the blue one:

    >>> square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    >>> nodes = np.concatenate([square, square + [0.25, 0.25, 1.0]])
    >>> faces = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    >>> rgba = np.array([[0, 0, 1, 1], [0, 0, 1, 1], [1, 0, 0, 1], [1, 0, 0, 1]], float)
    >>> image, extent = _rasterised(tuple(nodes.T.copy()), tuple(faces.T.copy()), lambda shown: rgba[shown])
    >>> image.shape[1], extent
    (770, (0.0, 1.25, 0.0, 1.25))
    >>> image[-5, -5].tolist(), image[5, 5].tolist(), image[-5, 5].tolist()
    ([1.0, 0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0], [0.0, 0.0, 0.0, 0.0])
    """
    # The face of every pixel's nearest sample (core.preview_kernel: the
    # culling and a depth buffer in passes over the faces; numpy gathers
    # the facing faces' corners and sorts the samples).
    found = jit.run("preview_kernel", "nearest_faces", columns, faces, size=len(faces[0]))
    nearest, lower, upper = found if found is not None else nearest_faces(columns, faces)
    if lower is None:
        return np.zeros((1, 1, 4)), (0.0, 1.0, 0.0, 1.0)
    scale, width, height = picture_frame(lower, upper)
    image = np.zeros((height * width, 4))
    drawn = nearest >= 0
    shown, which = np.unique(nearest[drawn], return_inverse=True)
    image[drawn] = colours_of(shown)[which.ravel()]
    extent = (float(lower[0]), float(lower[0] + (width - 1) / scale),
              float(lower[1]), float(lower[1] + (height - 1) / scale))
    return _fill_specks(image.reshape(height, width, 4)), extent


def picture_frame(lower: np.ndarray, upper: np.ndarray) -> tuple[float, int, int]:
    """Pixels per unit, width and height of the picture of a view's box
    (its lower and upper x and y): :data:`_PIXELS` wide.

    Examples
    --------
    >>> picture_frame(np.array([0.0, 0.0]), np.array([7.69, 1.0]))
    (100.0, 770, 101)
    """
    scale = (_PIXELS - 1) / max(float(upper[0] - lower[0]), 1e-12)
    return scale, _PIXELS, int(np.floor((upper[1] - lower[1]) * scale)) + 1


def nearest_faces(columns: tuple[np.ndarray, np.ndarray, np.ndarray], faces: tuple[np.ndarray, np.ndarray, np.ndarray]
                  ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """The face of the nearest sample in every pixel of the picture of the
    faces turned to the viewer (-1 where none fell), and the box of those
    faces' corners in x and y (None and None when no face is turned to it).

    ``columns`` are the nodes' x, y and depth in view coordinates, ``faces``
    the triangles' corners (three (T,) arrays); the picture's frame is
    :func:`picture_frame`'s, the samples :func:`nearest_triangles`'.
    """
    x, y, z = columns
    a, b, c = faces
    xa, ya = x.take(a), y.take(a)
    towards_eye = (x.take(b) - xa) * (y.take(c) - ya) - (y.take(b) - ya) * (x.take(c) - xa)
    del xa, ya
    # Only the faces turned to the viewer are drawn. Their corners one
    # coordinate at a time (three (T,) arrays each, gathered from contiguous
    # columns): (T, 3, 3) tables of them and their gathers took seconds on a city.
    facing = np.flatnonzero(towards_eye > 0)
    if len(facing) == 0:
        return np.full(1, -1, dtype=np.int64), None, None
    corners = [[column.take(corner.take(facing)) for column in columns] for corner in faces]
    lower = np.array([min(corner[axis].min() for corner in corners) for axis in range(2)])
    upper = np.array([max(corner[axis].max() for corner in corners) for axis in range(2)])
    scale, width, height = picture_frame(lower, upper)
    nearest = nearest_triangles([value for corner in corners for value in corner], float(lower[0]),
                                float(lower[1]), scale, width, height)
    return np.where(nearest >= 0, facing.take(np.maximum(nearest, 0)), -1), lower, upper


def nearest_triangles(corners: list[np.ndarray], left: float, bottom: float, scale: float, width: int,
                      height: int) -> np.ndarray:
    """The triangle of the nearest sample in every pixel of a ``height`` x
    ``width`` picture, -1 where none fell (row by row from the bottom).

    Parameters
    ----------
    corners : list of 9 ndarray (T,)
        x, y and depth (larger is nearer) of the triangles' first corner,
        then of the second and the third, in view coordinates.
    left, bottom, scale : float
        The picture's lower left corner in view coordinates, and pixels per unit.

    Notes
    -----
    Each triangle is sampled in proportion to its area on the picture (its
    centroid for one within a pixel), spread by the R2 low-discrepancy
    sequence folded into the triangle. The nearest sample of a pixel is the
    one least far behind the nearest of all, on a 31-bit scale; of equals,
    the first (by triangle, then sample).

    Examples
    --------
    A triangle and a smaller one nearer, over a 5 x 5 picture:

    >>> far = [np.array([v]) for v in (0.0, 0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 5.0, 0.0)]
    >>> near = [np.array([v]) for v in (0.0, 0.0, 1.0, 3.0, 0.0, 1.0, 0.0, 3.0, 1.0)]
    >>> picture = nearest_triangles([np.concatenate(pair) for pair in zip(far, near)], 0.0, 0.0, 1.0, 5, 5)
    >>> picture.reshape(5, 5)[::-1].tolist()  # top row first; -1: no sample fell there
    [[0, -1, -1, -1, -1], [1, 0, 0, -1, -1], [1, 1, 1, 0, -1], [1, 1, 1, 0, 0], [-1, 1, 1, 0, 0]]
    """
    x0, y0, z0, x1, y1, z1, x2, y2, z2 = corners
    # Pixel coordinates (depth kept) of the first corner and the two edges from it.
    pixel = [[(x - offset) * scale for x, offset in ((xk, left), (yk, bottom))] + [zk]
             for xk, yk, zk in ((x0, y0, z0), (x1, y1, z1), (x2, y2, z2))]
    origin, edge1, edge2 = pixel[0], minus(pixel[1], pixel[0]), minus(pixel[2], pixel[0])
    del pixel
    area = 0.5 * np.abs(edge1[0] * edge2[1] - edge1[1] * edge2[0])
    count = np.maximum(1, np.ceil(area * _SAMPLES_PER_PIXEL)).astype(np.int64)
    owner = np.repeat(np.arange(len(count)), count)
    j = np.arange(len(owner)) - np.repeat(np.cumsum(count) - count, count)
    u, v = (0.5 + j * _R2_U) % 1.0, (0.5 + j * _R2_V) % 1.0
    fold = u + v > 1.0
    u[fold], v[fold] = 1.0 - u[fold], 1.0 - v[fold]
    single = count[owner] == 1
    u[single] = v[single] = 1.0 / 3.0
    sample = [origin[axis].take(owner) + u * edge1[axis].take(owner) + v * edge2[axis].take(owner)
              for axis in range(3)]
    column = np.clip(np.rint(sample[0]), 0, width - 1).astype(np.int64)
    row = np.clip(np.rint(sample[1]), 0, height - 1).astype(np.int64)
    # Depth buffer: the nearest sample of every pixel, from one stable sort
    # of the pixel and the (31-bit) distance behind the nearest sample.
    depth = sample[2]
    nearest = np.full(height * width, -1, dtype=np.int64)
    if len(depth) == 0:
        return nearest
    behind = (depth.max() - depth) / max(float(depth.max() - depth.min()), 1e-300) * (2**31 - 1)
    key = (row * width + column) << 31 | behind.astype(np.int64)
    order = np.argsort(key, kind="stable")
    pixel_of = key[order] >> 31
    first = run_starts(pixel_of)
    nearest[pixel_of[first]] = owner[order[first]]
    return nearest


def _fill_specks(image: np.ndarray) -> np.ndarray:
    """Empty pixels surrounded by drawn ones (where no sample fell) take the
    colour of a drawn neighbour; the background around the model stays."""
    drawn = image[..., 3] > 0
    padded = np.pad(drawn, 1)
    h, w = drawn.shape
    shifts = [(di, dj) for di in (-1, 0, 1) for dj in (-1, 0, 1) if (di, dj) != (0, 0)]
    around = sum(padded[1 + di:h + 1 + di, 1 + dj:w + 1 + dj].astype(np.int8) for di, dj in shifts)
    speck = ~drawn & (around >= 6)
    filled = image.copy()
    for di, dj in shifts:  # the last drawn neighbour in this order gives the colour
        source = np.zeros_like(drawn)
        source[max(0, -di):h - max(0, di), max(0, -dj):w - max(0, dj)] = \
            drawn[max(0, di):h - max(0, -di), max(0, dj):w - max(0, -dj)]
        take = speck & source
        filled[take] = np.roll(image, (-di, -dj), axis=(0, 1))[take]
    return filled


@reusing_freed_memory()
def write_preview(path: str | Path, panels: list[tuple[SurfaceModel, str]],
                  block_heights: dict[int, float], is_cancelled: CancelCheck | None = None) -> Path:
    """Draw one or more models side by side (e.g. voxels, then the final mesh).

    Parameters
    ----------
    path : str or Path
        PNG file to write.
    panels : list of (SurfaceModel, title)
    block_heights : dict
        Height (m) of every block id, for the colours.
    is_cancelled : callable, optional
        Asked before each panel is drawn and before the file is written
        (:class:`core.errors.Cancelled` then, and no file).
    """
    # A figure of its own on the Agg canvas, not pyplot's: the host's backend
    # and open figures stay as they were (pyplot's switch of backend closes
    # them all), and QGIS draws this on a thread of its own.
    from matplotlib import cm
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure

    vmax = max(block_heights.values(), default=1.0)
    fig = Figure(figsize=(7 * len(panels), 6), dpi=110)
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, len(panels), squeeze=False)
    for ax, (model, title) in zip(axes[0], panels):
        check_cancel(is_cancelled)
        _panel(ax, model, block_heights, vmax, title)
    mappable = cm.ScalarMappable(cmap="viridis", norm=Normalize(0, vmax))
    fig.colorbar(mappable, ax=axes[0].tolist(), shrink=0.6, label="block height (m)")
    path = Path(path)
    check_cancel(is_cancelled)
    fig.savefig(path, bbox_inches="tight")
    return path
