"""Constrained, quality-controlled vertex-only Catmull-Clark smoothing (§4.1).

Catmull-Clark moves a vertex of valence ``n`` to ``(F + 2 R + (n - 3) P) / n``
where ``F`` is the mean of the centroids of its faces, ``R`` the mean of the
midpoints of its edges and ``P`` its position. The paper keeps the topology:
no face or edge point is inserted, only the vertices move, three passes.

Which surface moves a node (paper: "the position of a node located at the
interface ground/building and air/building is provided by the smoothing of
the building only"):

* a node of a block's surface moves with that block's faces (blocks never
  share a node: their voxel sets are well-composed);
* any other node of the ground moves with the ground's faces;
* every other node (air against the domain box) stays.

Constraints: a node on the ground/building/air line keeps its Z, so facades
stay vertical at the ground (paper §5); a node on the domain box stays on
its planes. Each pass keeps a move only if every face around the node stays
acceptable (:func:`core.quality.accept_moves`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .errors import Cancelled
from .quality import accept_moves
from .surface import AIR_REGION, GROUND_REGION, OUTSIDE_REGION, SurfaceModel


@dataclass
class NodeRoles:
    """How each node of a :class:`SurfaceModel` may move.

    Attributes
    ----------
    on_block, on_ground : ndarray of bool
        Node belongs to a block's / the ground's surface.
    foot : ndarray of bool
        Node on the ground/building/air line (keeps its Z).
    fixed_axes : ndarray of bool, shape (N, 3)
        Coordinates a node must keep (domain box planes, the foot's Z).
    movable : ndarray of bool
        Node moves at all.
    """

    on_block: np.ndarray
    on_ground: np.ndarray
    foot: np.ndarray
    fixed_axes: np.ndarray
    movable: np.ndarray

    @classmethod
    def of(cls, model: SurfaceModel, box_lower: np.ndarray, box_upper: np.ndarray) -> "NodeRoles":
        n = len(model.nodes)
        a, b = model.regions[:, 0], model.regions[:, 1]
        block_face = (a > 0) | (b > 0)
        ground_face = (a == GROUND_REGION) | (b == GROUND_REGION)
        ground_air = ((a == GROUND_REGION) & (b == AIR_REGION)) | ((a == AIR_REGION) & (b == GROUND_REGION))
        inner_face = (a != OUTSIDE_REGION) & (b != OUTSIDE_REGION)
        on_block = _nodes_of(model.quads[block_face], n)
        on_ground = _nodes_of(model.quads[ground_face], n)
        foot = on_block & _nodes_of(model.quads[ground_air], n)
        inside = _nodes_of(model.quads[inner_face], n)
        tol = 1e-9 * max(1.0, float(np.abs(box_upper - box_lower).max()))
        fixed_axes = (np.abs(model.nodes - box_lower) < tol) | (np.abs(model.nodes - box_upper) < tol)
        fixed_axes[:, 2] |= foot
        movable = (on_block | on_ground) & inside & ~fixed_axes.all(axis=1)
        return cls(on_block, on_ground, foot, fixed_axes, movable)


def _nodes_of(quads: np.ndarray, n: int) -> np.ndarray:
    mask = np.zeros(n, dtype=bool)
    mask[quads.ravel()] = True
    return mask


def catmull_clark_positions(nodes: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertex-only Catmull-Clark position of every node of a quad surface.

    Returns
    -------
    positions : ndarray of shape (N, 3)
        New positions (old ones for nodes the faces do not touch).
    touched : ndarray of bool
        Nodes the faces touch.

    Examples
    --------
    The corner of a cube of side 2 (valence 3) moves to (F + 2R) / 3,
    F and R the means of its face centres and edge midpoints:

    >>> nodes = np.array([[x, y, z] for z in (0, 2) for y in (0, 2) for x in (0, 2)], float)
    >>> cube = np.array([[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4],
    ...                  [1, 3, 7, 5], [3, 2, 6, 7], [2, 0, 4, 6]])
    >>> catmull_clark_positions(nodes, cube)[0][0]
    array([0.44444444, 0.44444444, 0.44444444])
    """
    n = len(nodes)
    centroid = nodes[quads].mean(axis=1)
    corners = quads.ravel()
    face_sum = _scatter(corners, np.repeat(centroid, 4, axis=0), n)
    face_count = np.bincount(corners, minlength=n)
    tail = quads.ravel()
    head = np.roll(quads, -1, axis=1).ravel()
    edges = np.unique(np.column_stack([np.minimum(tail, head), np.maximum(tail, head)]), axis=0)
    midpoint = 0.5 * (nodes[edges[:, 0]] + nodes[edges[:, 1]])
    ends = edges.ravel()
    edge_sum = _scatter(ends, np.repeat(midpoint, 2, axis=0), n)
    valence = np.bincount(ends, minlength=n)
    touched = (face_count > 0) & (valence > 0)
    positions = nodes.copy()
    v = valence[touched, None].astype(np.float64)
    f = face_sum[touched] / face_count[touched, None]
    r = edge_sum[touched] / v
    positions[touched] = (f + 2 * r + (v - 3) * nodes[touched]) / v
    return positions, touched


def _scatter(index: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    return np.column_stack([np.bincount(index, weights=values[:, c], minlength=n) for c in range(3)])


def smooth(model: SurfaceModel, roles: NodeRoles, passes: int = 3, threshold: float = 0.2,
           is_cancelled: Callable[[], bool] | None = None) -> tuple[np.ndarray, dict]:
    """Smooth buildings and ground; return new node positions and figures.

    Parameters
    ----------
    model : SurfaceModel
    roles : NodeRoles
    passes : int
        Catmull-Clark passes (paper: 3).
    threshold : float
        Minimum face quality a move may leave (see :mod:`core.quality`).

    Returns
    -------
    nodes : ndarray of shape (N, 3)
    stats : dict
        ``moved`` (node moves kept) and ``refused`` (moves undone) per pass.
    """
    a, b = model.regions[:, 0], model.regions[:, 1]
    block_quads = model.quads[(a > 0) | (b > 0)]
    ground_quads = model.quads[(a == GROUND_REGION) | (b == GROUND_REGION)]
    nodes = model.nodes.copy()
    stats = {"moved": [], "refused": []}
    for _ in range(passes):
        if is_cancelled is not None and is_cancelled():
            raise Cancelled()
        from_blocks, _ = catmull_clark_positions(nodes, block_quads)
        from_ground, _ = catmull_clark_positions(nodes, ground_quads)
        proposal = np.where(roles.on_block[:, None], from_blocks, from_ground)
        proposal = np.where(roles.fixed_axes | ~roles.movable[:, None], nodes, proposal)
        wanted = np.any(proposal != nodes, axis=1)
        nodes, kept = accept_moves(nodes, proposal, model.quads, threshold)
        stats["moved"].append(int(kept.sum()))
        stats["refused"].append(int((wanted & ~kept).sum()))
    return nodes, stats
