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

from . import jit
from .errors import Cancelled
from .parallel import in_background
from .progress import Text
from .quality import FaceState, accept_moves
from .surface import AIR_REGION, GROUND_REGION, OUTSIDE_REGION, SurfaceModel, unique_nodes
from .topology import changed_rows, sorted_unique, touching

#: The share of :func:`smooth`'s time its steps' tables take before the passes.
_TABLES_SHARE = 0.2


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
        tol = 1e-9 * max(1.0, float(np.abs(box_upper - box_lower).max()))
        # The same masks in a pass over the quads and one over the nodes (core.smooth_kernel).
        found = jit.run("smooth_kernel", "node_roles", model.quads, model.regions, model.nodes, box_lower, box_upper,
                        tol, GROUND_REGION, AIR_REGION, OUTSIDE_REGION, size=len(model.quads))
        if found is not None:
            return cls(*found)
        a, b = model.regions[:, 0], model.regions[:, 1]
        block_face = (a > 0) | (b > 0)
        ground_face = (a == GROUND_REGION) | (b == GROUND_REGION)
        ground_air = ((a == GROUND_REGION) & (b == AIR_REGION)) | ((a == AIR_REGION) & (b == GROUND_REGION))
        inner_face = (a != OUTSIDE_REGION) & (b != OUTSIDE_REGION)
        # take and compress: row gathers faster than indexing (core.vectors).
        on_block = _nodes_of(model.quads.compress(block_face, axis=0), n)
        on_ground = _nodes_of(model.quads.compress(ground_face, axis=0), n)
        foot = on_block & _nodes_of(model.quads.compress(ground_air, axis=0), n)
        inside = _nodes_of(model.quads.compress(inner_face, axis=0), n)
        fixed_axes = (np.abs(model.nodes - box_lower) < tol) | (np.abs(model.nodes - box_upper) < tol)
        fixed_axes[:, 2] |= foot
        movable = (on_block | on_ground) & inside & ~fixed_axes.all(axis=1)
        return cls(on_block, on_ground, foot, fixed_axes, movable)


def _nodes_of(quads: np.ndarray, n: int) -> np.ndarray:
    mask = np.zeros(n, dtype=bool)
    mask[quads.ravel()] = True
    return mask


class CatmullClarkStep:
    """The vertex-only Catmull-Clark step on one surface: ``step(positions)``
    gives the new positions of the surface's nodes ``step.nodes``.

    The topology never changes, so the step is linear in the positions, and
    it is made of two incidence matrices, each a plain table of the faces'
    (edges') nodes: ``A`` (nodes x faces, 1/4 per corner) gives the face
    centres ``A.T @ P``, and ``A @ centres`` a node's sum of them; ``B``
    (nodes x edges, 1/2 per end) does the same with the edge midpoints. The
    step keeps those tables (the faces' corners, the edges' ends); the
    compiled step (:mod:`core.smooth_kernel`) reads them as they are, and
    the numpy step makes the matrices from them, two sparse products with
    the positions per pass: the single ``n x n`` operator made from products
    of these matrices took longer to build than ten passes (3.4-5 s for 1.8 M
    quads, a pass 0.3 s).

    Parameters
    ----------
    quads : ndarray of int (M, 4)
        The surface's faces.
    n : int
        Number of nodes of the model (``quads`` index them).

    Examples
    --------
    The corner of a cube of side 2 (valence 3) moves to (F + 2R) / 3,
    F and R the means of its face centres and edge midpoints:

    >>> nodes = np.array([[x, y, z] for z in (0, 2) for y in (0, 2) for x in (0, 2)], float)
    >>> cube = np.array([[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4],
    ...                  [1, 3, 7, 5], [3, 2, 6, 7], [2, 0, 4, 6]])
    >>> step = CatmullClarkStep(cube, 8)
    >>> int(step.nodes[0]), step(nodes)[0]
    (0, array([0.44444444, 0.44444444, 0.44444444]))
    """

    def __init__(self, quads: np.ndarray, n: int):
        #: The surface's nodes (sorted), the rows of a step's result.
        self.nodes, faces = unique_nodes(quads, n)
        faces = faces.reshape(quads.shape)  # numbered by their row among self.nodes
        size = len(self.nodes)
        m = len(faces)
        ends = undirected_edges(faces, size)
        # The faces' corners and the edges' ends, int32 unless either table
        # is too large for it (then both int64, where scipy would widen one or
        # both matrices): the compiled step reads these tables alone. The
        # matrices (_incidence), whose values are all 1/4 and 1/2, are made
        # for the numpy step only. Their values and column pointers took
        # about 150 MB of arrays in the 1 km city's smoothing; the stage's
        # high-water mark fell from 2,016 to 1,740 MB without them.
        index = np.int32 if max(size, 4 * m + 1, len(ends) + 1) <= np.iinfo(np.int32).max else np.int64
        self._corners = faces.ravel().astype(index, copy=False)
        self._ends = ends.astype(index, copy=False)
        self._matrices: tuple[sparse.csc_matrix, sparse.csc_matrix] | None = None
        if jit.kernels("smooth_kernel", size) is None:
            self._incidence()  # the numpy step will run: made here, as the caller expects (on its thread)
        face_count = np.bincount(self._corners, minlength=size)
        valence = np.bincount(self._ends, minlength=size)
        # (F + 2 R + (n - 3) P) / n with F = (4 / faces) A A^T P and R = (2 / n) B B^T P.
        self._face_weight = (4.0 / face_count / valence)[:, None]
        self._edge_weight = (4.0 / valence / valence)[:, None]
        self._own_weight = ((valence - 3) / valence)[:, None]

    def tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The step as :func:`core.smooth_kernel.step_into` takes it: the
        faces' corners and the edges' ends (numbered as ``self.nodes``), and
        the weights of a node's face sum, edge sum and position."""
        return self._corners, self._ends, self._face_weight[:, 0], self._edge_weight[:, 0], self._own_weight[:, 0]

    def _incidence(self) -> tuple[sparse.csc_matrix, sparse.csc_matrix]:
        """``A`` and ``B`` (see the class doc), made at the first call, in CSC
        from the tables directly: column j holds the nodes of face (edge) j."""
        if self._matrices is None:
            size, m, e = len(self.nodes), len(self._corners) // 4, len(self._ends) // 2
            self._matrices = (
                sparse.csc_matrix((np.full(4 * m, 0.25), self._corners, np.arange(0, 4 * m + 1, 4)), shape=(size, m)),
                sparse.csc_matrix((np.full(2 * e, 0.5), self._ends, np.arange(0, 2 * e + 1, 2)), shape=(size, e)))
        return self._matrices

    def into(self, target: np.ndarray, positions: np.ndarray, which: np.ndarray) -> np.ndarray:
        """Write the new positions of the surface nodes ``self.nodes[which]``
        into ``target`` (N, 3), from all ``positions`` (N, 3); returns ``target``."""
        # The same sums, without the sparse products' tables (core.smooth_kernel).
        done = jit.run("smooth_kernel", "step_into", target, positions, self.nodes, which, *self.tables(),
                       size=len(self.nodes))
        if done is not None:
            return done
        target[self.nodes[which]] = self(positions).compress(which, axis=0)
        return target

    def __call__(self, positions: np.ndarray) -> np.ndarray:
        """New positions (len(self.nodes), 3) of the surface's nodes, from all ``positions`` (N, 3)."""
        p = positions.take(self.nodes, axis=0)  # faster than positions[self.nodes] (core.vectors)
        faces, edges = self._incidence()
        face_sum = faces @ (faces.T @ p)
        edge_sum = edges @ (edges.T @ p)
        return self._face_weight * face_sum + self._edge_weight * edge_sum + self._own_weight * p


def undirected_edges(faces: np.ndarray, size: int) -> np.ndarray:
    """Each undirected edge of ``faces`` once, as its two ends, the lower
    first, ordered by lower end then upper end, flat: ``[a0, b0, a1, b1, ...]``,
    in the faces' integer type.

    Examples
    --------
    >>> undirected_edges(np.array([[0, 1, 2, 3], [1, 4, 5, 2]]), 6).reshape(-1, 2).tolist()
    [[0, 1], [0, 3], [1, 2], [1, 4], [2, 3], [2, 5], [4, 5]]
    """
    # One compiled pass, the same rows (core.smooth_kernel).
    ends = jit.run("smooth_kernel", "undirected_edges", faces, size, size=len(faces))
    if ends is not None:
        return ends
    tail = faces.ravel()
    head = np.roll(faces, -1, axis=1).ravel()
    key = sorted_unique(np.minimum(tail, head).astype(np.int64) * size + np.maximum(tail, head))
    return np.column_stack([key // size, key % size]).ravel().astype(faces.dtype, copy=False)


def smooth(model: SurfaceModel, roles: NodeRoles, passes: int = 3, threshold: float = 0.2,
           is_cancelled: Callable[[], bool] | None = None,
           progress: Callable[[float, str], None] | None = None) -> tuple[np.ndarray, dict]:
    """Smooth buildings and ground; return new node positions and figures.

    Parameters
    ----------
    model : SurfaceModel
    roles : NodeRoles
    passes : int
        Catmull-Clark passes (paper: 3).
    threshold : float
        Minimum face quality a move may leave (see :mod:`core.quality`).
    progress : callable, optional
        ``progress(fraction, message)`` as each pass starts (the passes take
        about as long as each other; the steps' tables before them a fifth
        of the whole on the 1 km city).

    Returns
    -------
    nodes : ndarray of shape (N, 3)
    stats : dict
        ``moved`` (node moves kept) and ``refused`` (moves undone) per pass.
    """
    a, b = model.regions[:, 0], model.regions[:, 1]
    n = len(model.nodes)
    # Each node follows one surface: its block's, else the ground's. A
    # surface's step only needs the faces around the nodes that follow it
    # and move: a node's new position comes from its own faces and edges,
    # summed in the same order without the others. That leaves out the
    # ground's faces under the blocks and on the domain's bottom and sides,
    # two thirds of them on the 1 km city (2.1 M -> 0.74 M faces).
    follow_blocks = roles.movable & roles.on_block
    follow_ground = roles.movable & ~roles.on_block

    def step(on_surface: np.ndarray, following: np.ndarray) -> CatmullClarkStep:
        return CatmullClarkStep(model.quads.compress(on_surface & touching(following, model.quads), axis=0), n)

    # The two steps share nothing: the ground's is made on the background
    # thread (idle by now) while the blocks' is made here, mostly on one core.
    ground = in_background(step, (a == GROUND_REGION) | (b == GROUND_REGION), follow_ground)
    blocks = step((a > 0) | (b > 0), follow_blocks)
    ground = ground.result()
    from_blocks = follow_blocks[blocks.nodes]
    from_ground = follow_ground[ground.nodes]
    keep = roles.fixed_axes | ~roles.movable[:, None]
    nodes = model.nodes.copy()
    stats = {"moved": [], "refused": []}
    faces = FaceState.unknown(len(model.quads))  # what a pass leaves, the next one starts from
    for k in range(passes):
        if is_cancelled is not None and is_cancelled():
            raise Cancelled()
        if progress is not None:
            progress(_TABLES_SHARE + (1.0 - _TABLES_SHARE) * k / passes, Text("pass {} of {}", k + 1, passes))
        proposal = blocks.into(nodes.copy(), nodes, from_blocks)
        proposal = ground.into(proposal, nodes, from_ground)
        np.copyto(proposal, nodes, where=keep)
        wanted = changed_rows(proposal, nodes)
        nodes, kept = accept_moves(nodes, proposal, model.quads, threshold, is_cancelled=is_cancelled,
                                   state=faces, overwrite_new=True)
        del proposal
        stats["moved"].append(int(kept.sum()))
        stats["refused"].append(int((wanted & ~kept).sum()))
    return nodes, stats
