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
from scipy import sparse

from .errors import Cancelled
from .quality import FaceState, accept_moves
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


def catmull_clark_operator(quads: np.ndarray, n: int) -> tuple[sparse.csr_matrix, np.ndarray]:
    """The vertex-only Catmull-Clark step as one sparse ``n x n`` matrix.

    The topology never changes, so the step is linear in the node positions
    and the same every pass: ``new = W @ nodes``.

    Returns
    -------
    W : scipy.sparse.csr_matrix
        Rows of nodes the quads do not touch are zero.
    touched : ndarray of bool
        Nodes the quads touch.

    Examples
    --------
    The corner of a cube of side 2 (valence 3) moves to (F + 2R) / 3,
    F and R the means of its face centres and edge midpoints:

    >>> nodes = np.array([[x, y, z] for z in (0, 2) for y in (0, 2) for x in (0, 2)], float)
    >>> cube = np.array([[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4],
    ...                  [1, 3, 7, 5], [3, 2, 6, 7], [2, 0, 4, 6]])
    >>> W, _ = catmull_clark_operator(cube, 8)
    >>> (W @ nodes)[0]
    array([0.44444444, 0.44444444, 0.44444444])
    """
    m = len(quads)
    corner_face = np.repeat(np.arange(m), 4)
    incidence = sparse.csr_matrix((np.ones(4 * m), (quads.ravel(), corner_face)), shape=(n, m))
    face_count = np.asarray(incidence.sum(axis=1)).ravel()
    tail = quads.ravel()
    head = np.roll(quads, -1, axis=1).ravel()
    key = np.unique(np.minimum(tail, head).astype(np.int64) * n + np.maximum(tail, head))
    edges = np.column_stack([key // n, key % n])
    e = len(edges)
    edge_incidence = sparse.csr_matrix((np.ones(2 * e), (edges.ravel(), np.repeat(np.arange(e), 2))),
                                       shape=(n, e))
    valence = np.asarray(edge_incidence.sum(axis=1)).ravel()
    touched = (face_count > 0) & (valence > 0)
    inv_faces = np.divide(1.0, face_count, out=np.zeros(n), where=face_count > 0)
    inv_valence = np.divide(1.0, valence, out=np.zeros(n), where=valence > 0)
    # Each incidence matrix is dropped once used: on a city they are hundreds of MB.
    face_mean = sparse.diags(inv_faces) @ incidence @ (incidence.T * 0.25)        # F
    del incidence
    edge_mean = sparse.diags(inv_valence) @ edge_incidence @ (edge_incidence.T * 0.5)  # R
    del edge_incidence
    own = np.where(touched, (valence - 3) * inv_valence, 0.0)
    W = (sparse.diags(inv_valence) @ face_mean + sparse.diags(2 * inv_valence) @ edge_mean
         + sparse.diags(own))
    return W.tocsr(), touched


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
    n = len(model.nodes)
    # Each node follows one surface: its block's, else the ground's (one
    # operator made and narrowed to its nodes at a time, for the memory).
    from_blocks = sparse.diags(roles.on_block.astype(float)) @ catmull_clark_operator(
        model.quads[(a > 0) | (b > 0)], n)[0]
    from_ground = sparse.diags((~roles.on_block).astype(float)) @ catmull_clark_operator(
        model.quads[(a == GROUND_REGION) | (b == GROUND_REGION)], n)[0]
    W = from_blocks + from_ground
    del from_blocks, from_ground
    keep = roles.fixed_axes | ~roles.movable[:, None]
    nodes = model.nodes.copy()
    stats = {"moved": [], "refused": []}
    faces = FaceState.unknown(len(model.quads))  # what a pass leaves, the next one starts from
    for _ in range(passes):
        if is_cancelled is not None and is_cancelled():
            raise Cancelled()
        proposal = np.where(keep, nodes, W @ nodes)
        wanted = np.any(proposal != nodes, axis=1)
        nodes, kept = accept_moves(nodes, proposal, model.quads, threshold, is_cancelled=is_cancelled,
                                   state=faces)
        stats["moved"].append(int(kept.sum()))
        stats["refused"].append(int((wanted & ~kept).sum()))
    return nodes, stats
