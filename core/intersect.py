"""Self-intersection control of moved surfaces (paper §6: "the quality of the
mesh must be strictly controlled during the projection procedure").

Face quality and normal checks see one face at a time; a node pushed along
its normal can still cross a face of a thin neighbouring part, and a volume
mesher then refuses the model ("a segment and a facet intersect").
:func:`undo_crossings` finds the triangles that touch a moved node and cross
a triangle they do not share a node with, and undoes the moves of their
nodes until none is left.

Broad phase: a KD-tree over triangle centres, pairs closer than the largest
triangle diameter. Narrow phase: an edge of one triangle crossing the other
(Moller-Trumbore on segments), both ways; coplanar touching is not reported.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.spatial import cKDTree

from .errors import Cancelled
from .quality import best_split


def crossing_triangles(nodes: np.ndarray, triangles: np.ndarray, focus: np.ndarray,
                       chunk: int = 20_000, is_cancelled: Callable[[], bool] | None = None) -> np.ndarray:
    """Pairs ``(a, b)`` of triangles that cross, ``a`` among the ``focus`` ones.

    Examples
    --------
    Two triangles piercing each other, and a third far away:

    >>> nodes = np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0],
    ...                   [0.5, 0.5, -1], [0.5, 0.5, 1], [3, 3, 0],
    ...                   [9, 9, 9], [10, 9, 9], [9, 10, 9]], float)
    >>> tris = np.array([[0, 1, 2], [3, 4, 5], [6, 7, 8]])
    >>> crossing_triangles(nodes, tris, np.array([0, 2])).tolist()
    [[0, 1]]
    """
    if len(focus) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    p = nodes[triangles]
    centre = p.mean(axis=1)
    reach = np.linalg.norm(p - centre[:, None, :], axis=2).max()
    lower, upper = p.min(axis=1), p.max(axis=1)
    everything = cKDTree(centre)
    found = []
    for start in range(0, len(focus), chunk):
        if is_cancelled is not None and is_cancelled():
            raise Cancelled()
        part = focus[start:start + chunk]
        pairs = cKDTree(centre[part]).sparse_distance_matrix(everything, 2 * reach, output_type="ndarray")
        a = part[pairs["i"]]
        b = pairs["j"].astype(np.int64)
        # Bounding boxes must overlap; triangles sharing a node touch by
        # construction, and the quality control already covers them.
        keep = np.all((lower[a] <= upper[b]) & (lower[b] <= upper[a]), axis=1)
        a, b = a[keep], b[keep]
        shared = (triangles[a][:, :, None] == triangles[b][:, None, :]).any(axis=(1, 2))
        a, b = a[~shared], b[~shared]
        crossing = _edges_cross(p[a], p[b]) | _edges_cross(p[b], p[a])
        found.append(np.column_stack([a[crossing], b[crossing]]))
    return np.concatenate(found)


def _edges_cross(edges_of: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Whether an edge of each triangle in ``edges_of`` crosses the paired triangle."""
    v0, v1, v2 = faces[:, 0], faces[:, 1], faces[:, 2]
    e1, e2 = v1 - v0, v2 - v0
    hit = np.zeros(len(faces), dtype=bool)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        origin = edges_of[:, i]
        direction = edges_of[:, j] - origin
        h = np.cross(direction, e2)
        det = np.einsum("ij,ij->i", e1, h)
        ok = np.abs(det) > 1e-12 * np.maximum(np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1), 1e-300) \
            * np.maximum(np.linalg.norm(direction, axis=1), 1e-300)
        inv = np.divide(1.0, det, out=np.zeros_like(det), where=ok)
        s = origin - v0
        u = inv * np.einsum("ij,ij->i", s, h)
        q = np.cross(s, e1)
        v = inv * np.einsum("ij,ij->i", direction, q)
        t = inv * np.einsum("ij,ij->i", e2, q)
        eps = 1e-9
        hit |= ok & (u > eps) & (v > eps) & (u + v < 1 - eps) & (t > eps) & (t < 1 - eps)
    return hit


def undo_crossings(old: np.ndarray, new: np.ndarray, moved: np.ndarray, quads: np.ndarray,
                   max_rounds: int = 20,
                   is_cancelled: Callable[[], bool] | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """Undo moves until no moved triangle crosses another.

    Parameters
    ----------
    old, new : ndarray (N, 3)
        Positions before and after the moves.
    moved : ndarray of bool (N,)
        Nodes whose move was kept so far.
    quads : ndarray (M, 4)
        Every face of the model.

    Returns
    -------
    positions, moved, undone
        Updated positions and mask, and how many moves were undone.
    """
    positions = new.copy()
    moved = moved.copy()
    undone = 0
    near = None  # after a round, only the neighbourhood of what was undone can still cross
    for _ in range(max_rounds):
        triangles, _ = best_split(positions, quads)
        focus = moved[triangles].any(axis=1)
        if near is not None:
            centre = positions[triangles].mean(axis=1)
            focus &= np.all((centre >= near[0]) & (centre <= near[1]), axis=1)
        pairs = crossing_triangles(positions, triangles, np.flatnonzero(focus), is_cancelled=is_cancelled)
        if len(pairs) == 0:
            break
        culprits = np.unique(triangles[pairs.ravel()])
        culprits = culprits[moved[culprits]]
        if len(culprits) == 0:
            break  # crossings not caused by these moves
        positions[culprits] = old[culprits]
        moved[culprits] = False
        undone += len(culprits)
        span = 4 * np.linalg.norm(np.ptp(positions[quads[0]], axis=0))  # a few faces around
        near = (np.minimum(old[culprits], new[culprits]).min(axis=0) - span,
                np.maximum(old[culprits], new[culprits]).max(axis=0) + span)
    return positions, moved, undone
