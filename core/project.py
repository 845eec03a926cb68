"""Nodal normals and projection of the nodes onto the data (§4.2).

For every node: its normal is the mean of the normals of its faces, each
quad split into the two triangles that maximise the shape quality
(:func:`core.quality.best_split`). Then, as in the paper:

1. the data point closest to the line through the node along its normal is
   chosen among the points near the node;
2. the data points around it fit a moving-least-squares plane (weighted
   principal axes, Gaussian weights; :mod:`core.mls`);
3. if that plane's normal is compatible with the node's (angle below
   ``max_angle``), the node moves along its normal onto the plane;
   otherwise the next data point is tried;
4. the move is kept only if the faces around the node stay acceptable
   (:func:`core.quality.accept_moves`) and no face it moves crosses another
   (:func:`core.intersect.undo_crossings`).

Everything is batched over nodes (KD-tree queries and a closed-form 3 x 3
eigen-solver); the candidate loop runs a fixed few times, not per node.
With numba (:mod:`core.jit`) the searches go through a compiled index of
columns (:mod:`core.neighbours_kernel`) and step 1 runs compiled, the
nearest points and the choice among them in one pass per node
(:mod:`core.projection_kernel`): the same points, in less than half the time.
The normals are summed compiled too (:mod:`core.normals_kernel`).
"""
from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.spatial import cKDTree

from . import jit
from .errors import Cancelled
from .intersect import undo_crossings
from .mls import PlaneCache
from .neighbours import PointSearch, by_value_then_coordinates, nearest, point_index
from .parallel import map_blocks, row_blocks
from .progress import counted
from .quality import accept_moves, quad_normals
from .smooth import NodeRoles
from .surface import GROUND_REGION, SurfaceModel
from .topology import changed_rows, touching
from .vectors import dot, length

#: Data points examined around each node, planes tried per node.
_NEAR, _TRIES = 24, 3
#: Side of the columns of the compiled point index, in voxels (core.neighbours_kernel):
#: the candidates' search radius (1.5 voxels) spans two or three of them.
COLUMN_VOXELS = 1.5
#: Quads whose normals numpy makes per block of rows (temporaries of a few MB).
_FIT_ROWS = 16384
#: Nodes whose candidate points are searched at a time, and ranked at a time.
_QUERY_ROWS, _LINE_ROWS = 1 << 17, 4096

#: The parts of :func:`project_nodes`, in order, with their seconds for the
#: block nodes of the 1 km synthetic city at 1 m: the share of the progress
#: bar each takes of the parts a call runs (the ground's skips the crossings).
_PART_SECONDS = {"nodal normals": 0.3, "nearest data points": 0.61, "moving-least-squares planes": 1.45,
                 "quality control": 0.22, "face crossings": 2.17}
#: The share of the planes' part a try's fitting takes of what is left of it
#: (the first try fits the planes of most nodes).
_FIRST_TRY_SHARE = 0.9


def node_normals(nodes: np.ndarray, quads: np.ndarray, n: int) -> np.ndarray:
    """Unit normal of every node: mean of the unit normals of its quads.

    A quad's normal is the sum of the normals of the two triangles of its
    best split (paper §4.2). The two triangles of either split have normals
    (cross products) that add up to the cross product of the quad's
    diagonals, so that sum is taken without splitting. Nodes touched by no
    quad get a zero vector.

    Examples
    --------
    >>> nodes = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    >>> node_normals(nodes, np.array([[0, 1, 2, 3]]), 4)[0]
    array([0., 0., 1.])
    """
    # The same sums, without a pass over all nodes per corner and coordinate (core.normals_kernel).
    found = jit.run("normals_kernel", "node_normals", nodes, quads, n, size=len(quads))
    if found is not None:
        return found
    normal = np.empty((3, len(quads)))

    def fill(rows: slice) -> None:
        # Halving the cross product is exact: the unit normal is unchanged.
        w = quad_normals(nodes, quads[rows]).T
        normal[:, rows] = w / np.maximum(length(w), 1e-300)

    # Blocks of quads on all cores: a block's temporaries stay in the cache.
    map_blocks(fill, row_blocks(len(quads), _FIT_ROWS))
    summed = np.zeros((3, n))
    for k in range(4):
        for c in range(3):
            summed[c] += np.bincount(quads[:, k], weights=normal[c], minlength=n)
    summed = summed.T
    size = np.linalg.norm(summed, axis=1, keepdims=True)
    return np.divide(summed, size, out=np.zeros(summed.shape), where=size > 0)  # float when no quad


def outward_normals(model: SurfaceModel, nodes: np.ndarray, roles: NodeRoles,
                    select: np.ndarray | None = None) -> np.ndarray:
    """Normals pointing out of the region that owns each node (block, else ground).

    Parameters
    ----------
    select : ndarray of bool (N,), optional
        Nodes whose normal is wanted; the faces touching none of them are
        not looked at. Default: all nodes.

    Returns
    -------
    ndarray (S, 3)
        A unit normal (a zero vector where the faces' normals cancel) for
        each ``select`` node, in node order.
    """
    n = len(nodes)
    if select is None:
        select = np.ones(n, dtype=bool)
    # The same sums on the model's quads as they are, not on gathered copies (core.normals_kernel).
    found = jit.run("normals_kernel", "outward_node_normals", nodes, model.quads, model.regions,
                    roles.on_block, select, GROUND_REGION, size=len(model.quads))
    if found is not None:
        return found
    normal = np.zeros((n, 3))
    # The faces of a surface are gathered only where a wanted node follows
    # it: the projection asks for the blocks' nodes, then mostly the ground's.
    for faces_of, wanted in ((lambda: model.block_faces()[0], select & roles.on_block),
                             (lambda: model.closed_surface(GROUND_REGION), select & ~roles.on_block)):
        if wanted.any():
            # The faces around the wanted nodes, in their order: each node's
            # sum runs over the same faces in the same order as with all faces.
            quads = faces_of()
            quads = quads.compress(touching(wanted, quads), axis=0)
            np.copyto(normal, node_normals(nodes, quads, n), where=wanted[:, None])
    return normal.compress(select, axis=0)


def project_nodes(model: SurfaceModel, nodes: np.ndarray, roles: NodeRoles, select: np.ndarray,
                  data: np.ndarray, voxel_size: float, threshold: float,
                  max_angle: float = 45.0, max_distance: float = 1.5, check_crossings: bool = True,
                  is_cancelled: Callable[[], bool] | None = None,
                  tree: PointSearch | None = None,
                  progress: Callable[[float, str], None] | None = None) -> tuple[np.ndarray, dict]:
    """Project the ``select`` nodes onto ``data`` through MLS planes.

    Parameters
    ----------
    model : SurfaceModel
    nodes : ndarray (N, 3)
        Current (smoothed) positions.
    roles : NodeRoles
    select : ndarray of bool (N,)
        Nodes to project on this data set.
    data : ndarray (P, 3)
        Data points (local coordinates).
    voxel_size : float
    threshold : float
        Minimum face quality.
    max_angle : float
        Largest angle (degrees) between a node normal and a plane normal.
    max_distance : float
        Largest move and search radius, in voxel sizes.
    check_crossings : bool
        Undo moves that make a face cross another (:mod:`core.intersect`).
    tree : cKDTree or ColumnIndex, optional
        A search over ``data`` the caller has: a KD-tree (with numba a
        compiled index is made instead, :func:`core.neighbours.point_index`)
        or that index. Made when not given.
    progress : callable, optional
        ``progress(fraction, message)`` as each part starts, and within the
        planes' as the nodes find theirs.

    Returns
    -------
    nodes : ndarray (N, 3)
    stats : dict
        ``projected`` (moves kept), ``no_plane`` (no compatible plane),
        ``refused`` (moves undone by the quality control) and ``crossing``
        (of those, undone because a face would cross another).
    """
    select = select & roles.movable
    idx_nodes = np.flatnonzero(select)
    stats = {"projected": 0, "no_plane": 0, "refused": 0}
    if len(idx_nodes) == 0 or len(data) < 3:
        return nodes, stats
    if is_cancelled is not None and is_cancelled():
        raise Cancelled()
    report_part = _part_reporter(progress, check_crossings)
    report_part("nodal normals")
    normal = outward_normals(model, nodes, roles, select)
    # take and compress: row gathers faster than indexing (core.vectors).
    fixed_axes = roles.fixed_axes.take(idx_nodes, axis=0)
    # Constrained coordinates are not moved: drop them from the direction.
    normal[fixed_axes] = 0.0
    size = np.linalg.norm(normal, axis=1, keepdims=True)
    usable = size[:, 0] > 1e-6
    normal = np.divide(normal, size, out=np.zeros_like(normal), where=size > 0)
    p = nodes.take(idx_nodes, axis=0)
    report_part("nearest data points")
    tree = point_index(data, COLUMN_VOXELS * voxel_size, tree)
    target, stats["no_plane"] = _plane_targets(tree, data, p, normal, usable, max_distance * voxel_size,
                                               voxel_size, max_angle, is_cancelled, report_part)
    # An index made here (200 MB for the ground of the 1 km city) is not held
    # through the controls either; the caller's is its own to keep.
    del normal, size, tree
    proposal = nodes.copy()
    proposal[idx_nodes] = np.where(fixed_axes, p, target)
    del p, target
    wanted = changed_rows(proposal, nodes)
    report_part("quality control")
    result, kept = accept_moves(nodes, proposal, model.quads, threshold, is_cancelled=is_cancelled,
                                overwrite_new=True)
    del proposal
    # A node pushed along its normal may cross a face of a thin neighbouring part.
    stats["crossing"] = 0
    if check_crossings:
        report_part("face crossings")
        result, kept, stats["crossing"] = undo_crossings(
            nodes, result, kept & wanted, model.quads, is_cancelled=is_cancelled, overwrite_new=True,
            progress=lambda fraction, message: report_part("face crossings", fraction))
    stats["projected"] = int((wanted & kept).sum())
    stats["refused"] = int((wanted & ~kept).sum())
    return result, stats


def _part_reporter(progress: Callable[[float, str], None] | None,
                   check_crossings: bool) -> Callable[[str, float], None]:
    """``report_part(part, done=0.0)``: ``progress`` at the share ``done`` of
    one of :data:`_PART_SECONDS`' parts, among those a call runs (the name
    ``report_part`` is what ``scripts/i18n.py`` collects their texts by)."""
    parts = [name for name in _PART_SECONDS if check_crossings or name != "face crossings"]
    seconds = np.array([_PART_SECONDS[name] for name in parts])
    starts = dict(zip(parts, np.concatenate([[0.0], np.cumsum(seconds)[:-1]]) / seconds.sum()))
    shares = dict(zip(parts, seconds / seconds.sum()))

    def report_part(name: str, done: float = 0.0) -> None:
        if progress is not None:
            progress(float(starts[name] + shares[name] * done), name)
    return report_part


def _plane_targets(tree: PointSearch, data: np.ndarray, p: np.ndarray, normal: np.ndarray, usable: np.ndarray,
                   radius: float, voxel_size: float, max_angle: float,
                   is_cancelled: Callable[[], bool] | None = None,
                   report_part: Callable[[str, float], None] | None = None) -> tuple[np.ndarray, int]:
    """Where each node ``p`` meets the first compatible plane along its unit
    ``normal`` (steps 1 to 3 of the module doc), the node itself where no
    plane is (or where it is not ``usable``); and how many nodes found none.

    A function of its own so that its tables (the candidates, the planes
    fitted, the last try's rows) are freed before the quality and crossing
    controls, which hold the projection's peak of memory: on the 1 km city
    the resident memory rose to 2,070 MB in the buildings' crossing control
    with them held, to 1,870 MB without.
    """
    searched = None
    if report_part is not None:  # as the threads find the nodes' points
        searched = counted(lambda share: report_part("nearest data points", share), len(p))
    candidates = _candidates(tree, data, p, normal, radius, _TRIES, is_cancelled, searched)
    cos_max = np.cos(np.radians(max_angle))
    target = p.copy()
    done = ~usable
    planes = PlaneCache(data, tree, 0.5 * voxel_size)
    reported = 0.0  # the bar never goes back where a try's estimate ran ahead
    for attempt in range(candidates.shape[1]):
        if is_cancelled is not None and is_cancelled():
            raise Cancelled()
        todo = np.flatnonzero(~done & (candidates[:, attempt] < len(data)))
        if len(todo) == 0:
            break
        fitted = None
        if report_part is not None:
            # The share of the nodes that found their plane, and within a try
            # (the first: most find it there) the share of its planes fitted.
            before = 1.0 - len(todo) / max(len(p), 1)

            def fitted(share: float, before: float = before) -> None:
                nonlocal reported
                reported = max(reported, before + (1.0 - before) * _FIRST_TRY_SHARE * share)
                report_part("moving-least-squares planes", reported)
            fitted(0.0)
        centre, plane_normal, flat = planes(candidates[todo, attempt], fitted)
        normal_todo = normal.take(todo, axis=0)
        cos = np.einsum("qc,qc->q", plane_normal, normal_todo)
        compatible = flat & (np.abs(cos) >= cos_max)
        t = np.einsum("qc,qc->q", centre - p.take(todo, axis=0), plane_normal) / np.where(compatible, cos, 1.0)
        compatible &= np.abs(t) <= radius
        ok = todo[compatible]
        target[ok] = p.take(ok, axis=0) + t[compatible, None] * normal_todo.compress(compatible, axis=0)
        done[ok] = True
    return target, int((~done).sum())


def _candidates(tree: PointSearch, data: np.ndarray, p: np.ndarray, normal: np.ndarray, radius: float,
                tries: int, is_cancelled: Callable[[], bool] | None = None,
                searched: Callable[[int], None] | None = None) -> np.ndarray:
    """The data points each node tries, best first (step 1 of the module doc).

    Among the ``_NEAR`` data points within ``radius`` of each node ``p``, the
    ``tries`` closest to the line through it along its ``normal`` (ties by
    coordinates, :func:`_ranked`).

    Through a compiled index, all the nodes in one pass that makes no such
    tables (:func:`core.projection_kernel.candidates_near_lines`). Else the
    nodes are taken ``_QUERY_ROWS`` at a time: the neighbour tables (nodes x
    24 indices, distances, distances to the line, their ranks) are needed
    only to pick a few points per node, and on a city, all at once, they
    took gigabytes. Each node's points depend on its own row only.
    ``searched(count)`` is told of each block of nodes done.

    Returns
    -------
    ndarray of int (Q, min(tries, _NEAR, P))
        Data point indices; ``len(data)`` where there are fewer points.
    """
    if not isinstance(tree, cKDTree):
        # The same points from the compiled index, without the tables of
        # nearest points (core.projection_kernel): all the nodes at once.
        chosen = jit.run("projection_kernel", "candidates_near_lines", tree, p, normal, _NEAR, radius, tries, None,
                         is_cancelled, searched, size=len(p))
        if chosen is not None:
            return chosen
    k = min(_NEAR, len(data))
    candidates = np.empty((len(p), min(tries, k)), dtype=np.intp)
    for rows in row_blocks(len(p), _QUERY_ROWS):
        if is_cancelled is not None and is_cancelled():
            raise Cancelled()
        near = nearest(tree, data, p[rows], _NEAR, radius)[1]
        # The same points, one compiled pass per node (core.projection_kernel).
        chosen = jit.run("projection_kernel", "closest_to_lines", data, near, p[rows], normal[rows], tries,
                         size=len(p))
        if chosen is not None:
            candidates[rows] = chosen
        else:
            out = candidates[rows]
            start = rows.start

            def rank(part: slice, near: np.ndarray = near, out: np.ndarray = out, start: int = start) -> None:
                # Each node's points from its own row: blocks of rows on all
                # cores, their tables in the cache.
                where = slice(start + part.start, start + part.stop)
                off_line = _distance_to_line(data, near[part], p[where], normal[where])
                # A missing neighbour is infinitely far from the line, and its index is len(data).
                out[part] = np.take_along_axis(near[part], _ranked(off_line, near[part], data, tries), axis=1)

            map_blocks(rank, row_blocks(len(near), _LINE_ROWS))
        if searched is not None:
            searched(len(near))
    return candidates


def _ranked(off_line: np.ndarray, near: np.ndarray, data: np.ndarray, tries: int) -> np.ndarray:
    """Columns of the ``tries`` smallest ``off_line`` of every row, smallest first.

    Ties (data on a lattice) are broken by the points' coordinates, not by
    the KD-tree's visiting order: a tile then picks the points a whole run
    picks. That is a sort of each row by (distance, x, y, z); a partial
    selection of the ``tries + 1`` smallest distances gives the same columns
    on the rows where these distances strictly increase, and only the other
    rows are sorted in full. Where missing neighbours (``inf``) make the
    first ``tries``, which of them comes is of no matter: the caller skips
    infinite distances.

    Parameters
    ----------
    off_line : ndarray (Q, K)
        Distance of each neighbour to the node's line, ``inf`` when missing.
    near : ndarray of int (Q, K)
        The neighbours (``len(data)`` when missing).
    data : ndarray (P, 3)
    tries : int

    Returns
    -------
    ndarray of int (Q, min(tries, K))
    """
    q, k = off_line.shape
    tries = min(tries, k)
    if k <= tries + 1 or q == 0:
        unsure = np.arange(q)
        ranked = np.zeros((q, tries), dtype=np.intp)
    else:
        # The tries + 1 smallest, in any order, then in order (a sort of few columns).
        few = np.argpartition(off_line, tries, axis=1)[:, :tries + 1]
        few = np.take_along_axis(few, np.argsort(np.take_along_axis(off_line, few, axis=1), axis=1), axis=1)
        value = np.take_along_axis(off_line, few, axis=1)
        increasing = (value[:, 1:] > value[:, :-1]) | (value[:, 1:] == np.inf)
        ranked = few[:, :tries]
        unsure = np.flatnonzero(~increasing.all(axis=1))
    if len(unsure):
        ranked[unsure] = by_value_then_coordinates(off_line[unsure], near[unsure], data, tries)
    return ranked


def _distance_to_line(data: np.ndarray, near: np.ndarray, p: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Distance of the data points ``near`` (Q, K) to the line through each
    node ``p`` along its ``normal`` (Q, 3); ``inf`` for missing neighbours
    (index ``len(data)``).

    The arithmetic of ``offset = data[near] - p``, ``along =
    np.einsum("qkc,qc->qk", offset, normal)`` and
    ``np.linalg.norm(offset - along * normal)``, one (Q, K) array per
    coordinate with :mod:`core.vectors` (operations on (Q, K, 3) arrays
    broadcast along an axis of three run ufunc loops three elements long).
    It is elementwise: :func:`_candidates` calls it on blocks of a few
    thousand rows, whose temporaries stay in the cache.

    Examples
    --------
    >>> data = np.array([[3.0, 4.0, 7.0], [0.0, 0.0, -2.0]])
    >>> _distance_to_line(data, np.array([[0, 1, 2]]), np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]))
    array([[ 5.,  0., inf]])
    """
    found = near < len(data)
    x = data.take(np.where(found, near, 0), axis=0)
    offset = [x[..., c] - p[:, c, None] for c in range(3)]
    direction = [normal[:, c, None] for c in range(3)]
    along = dot(offset, direction)
    distance = length([offset[c] - along * direction[c] for c in range(3)])
    distance[~found] = np.inf
    return distance
