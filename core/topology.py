"""Topology and measures of polygon surfaces: closed, 2-manifold, outward, volume.

These are the checks every output must pass (a volume mesher or a solver
accepts a surface only if it is closed and manifold), and the measures the
block attributes use; also which faces touch given nodes, and which nodes
moved, the selections every quality-controlled step makes. Faces are given
as an ``(M, k)`` array of node indices (quads or triangles), all oriented
the same way round.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from . import jit

#: Rows from which the compiled selections run (core.topology_kernel): below,
#: handing blocks to the threads costs more than numpy's passes.
_KERNEL_ROWS = 1 << 16


def touching(marked: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Which faces have a corner at a marked node: ``marked[faces].any(axis=1)``.

    One gather per corner column: numpy's ``any`` over rows three or four
    long costs three times as much on millions of faces.

    Examples
    --------
    >>> touching(np.array([False, True, False, False]), np.array([[0, 1, 2], [0, 2, 3]])).tolist()
    [True, False]
    """
    if len(faces) >= _KERNEL_ROWS:
        found = jit.run("topology_kernel", "touching", marked, faces, size=len(faces))
        if found is not None:
            return found
    hit = marked[faces[:, 0]]
    for k in range(1, faces.shape[1]):
        hit |= marked[faces[:, k]]
    return hit


def sorted_unique(values: np.ndarray, return_inverse: bool = False):
    """``np.unique(values, return_inverse=...)`` of a 1-D array, by numpy's
    stable sort.

    For integers that is timsort, which runs several times faster than the
    quicksort of ``np.unique`` on values that come nearly in order or in
    runs, as the edge keys of faces listed in lattice order (5 M keys of the
    500 m city's ground: 0.29 -> 0.1 s) and the cells of points sampled
    triangle by triangle do (5 M points of the Zurich mesh: 0.67-0.8 ->
    0.23 s, with the inverse). The values and the inverse are those of
    ``np.unique``, whatever the sort.

    Examples
    --------
    >>> sorted_unique(np.array([3, 1, 3, 2, 1])).tolist()
    [1, 2, 3]
    >>> [a.tolist() for a in sorted_unique(np.array([3, 1, 3]), return_inverse=True)]
    [[1, 3], [1, 0, 1]]
    """
    if not return_inverse:
        ordered = np.sort(values, kind="stable")
        return ordered[run_starts(ordered)]
    order = np.argsort(values, kind="stable")
    ordered = values[order]
    first = run_starts(ordered)
    inverse = np.empty(len(values), dtype=np.intp)
    inverse[order] = np.cumsum(first) - 1
    return ordered[first], inverse


def stable_order(key: np.ndarray, n_keys: int) -> np.ndarray:
    """``np.argsort(key, kind="stable")`` of integer keys ``0..n_keys-1``.

    Keys that fit in 16 bits are sorted as such: numpy's stable sort of
    16-bit integers is a radix sort, where wider ones are merged (the 1 km
    city's 3.6 M block triangles by block: 0.085 -> 0.025 s). The same order.

    Examples
    --------
    >>> stable_order(np.array([2, 0, 2, 1, 0]), 3).tolist()
    [1, 4, 3, 0, 2]
    """
    if n_keys <= 1 << 16:
        key = key.astype(np.uint16)
    return np.argsort(key, kind="stable")


def dense_unique(values: np.ndarray, return_inverse: bool = False):
    """``np.unique(values, return_inverse=...)`` of integers of a small range
    (region ids, region pairs), the inverse flat whatever the shape of
    ``values`` (as numpy 1 gives it; numpy 2's takes their shape): a mark
    per value of the range and a running count, in linear time, where the
    range is no larger than twice the values (else ``np.unique``). The
    9.7 M region ids of the 1 km city's triangles: 0.41 s by a sort.

    Examples
    --------
    >>> dense_unique(np.array([[3, -1], [3, 7]])).tolist()
    [-1, 3, 7]
    >>> [a.tolist() for a in dense_unique(np.array([5, -2, 5]), return_inverse=True)]
    [[-2, 5], [1, 0, 1]]
    """
    flat = values.ravel()
    # Integers that intp holds (not uint64) only.
    if len(flat) == 0 or flat.dtype.kind not in "iu" or flat.dtype == np.uint64:
        return np.unique(flat, return_inverse=return_inverse)
    low, high = int(flat.min()), int(flat.max())
    if high - low >= max(2 * len(flat), 1024):
        return np.unique(flat, return_inverse=return_inverse)
    offset = flat.astype(np.intp, copy=False) - low  # in intp: small types would overflow
    present = np.zeros(high - low + 1, dtype=bool)
    present[offset] = True
    unique = (np.flatnonzero(present) + low).astype(flat.dtype)
    if not return_inverse:
        return unique
    rank = np.cumsum(present, dtype=np.intp) - 1
    return unique, rank[offset]


def run_starts(values: np.ndarray) -> np.ndarray:
    """Where each run of equal values of a 1-D array starts: the first value,
    and every value unlike the one before it.

    Examples
    --------
    >>> run_starts(np.array([4, 4, 2, 2, 2, 4])).tolist()
    [True, False, True, False, False, True]
    """
    starts = np.ones(len(values), dtype=bool)
    np.not_equal(values[1:], values[:-1], out=starts[1:])
    return starts


def sorted_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rows of a 2-D array in the order ``np.unique(rows, axis=0)`` sorts them (first
    column first; equal rows in their order, a stable sort) and where each run of equal rows
    starts in that order. From a lexsort of the columns: several times faster than unique's
    sort of the rows as records (a city's vertices, 3 M rows: ~1 s less).

    ``rows[order[starts]]`` are unique's rows, ``order[starts]`` its ``return_index``, and
    ``np.cumsum(starts) - 1`` put back at ``order`` its ``return_inverse``.

    Examples
    --------
    >>> order, starts = sorted_rows(np.array([[1, 2], [0, 5], [1, 2], [0, 3]]))
    >>> order.tolist(), starts.tolist()
    ([3, 1, 0, 2], [True, True, True, False])
    """
    order = np.lexsort(rows.T[::-1])
    ordered = rows.take(order, axis=0)
    starts = np.ones(len(rows), dtype=bool)
    np.any(ordered[1:] != ordered[:-1], axis=1, out=starts[1:])
    return order, starts


def unique_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(rows, axis=0, return_inverse=True)``, by :func:`sorted_rows`: the unique
    rows in order, and for every row the number of its unique row.

    Examples
    --------
    >>> unique, inverse = unique_rows(np.array([[1, 2], [0, 5], [1, 2]]))
    >>> unique.tolist(), inverse.tolist()
    ([[0, 5], [1, 2]], [1, 0, 1])
    """
    order, starts = sorted_rows(rows)
    inverse = np.empty(len(rows), dtype=np.int64)
    inverse[order] = np.cumsum(starts) - 1
    return rows.take(order[starts], axis=0), inverse


def changed_rows(new: np.ndarray, old: np.ndarray) -> np.ndarray:
    """Rows of two (N, 3) position tables that differ: ``np.any(new != old, axis=1)``.

    Examples
    --------
    >>> changed_rows(np.array([[0.0, 1, 2], [3, 4, 5]]), np.array([[0.0, 1, 2], [3, 4, 6]])).tolist()
    [False, True]
    """
    if len(new) >= _KERNEL_ROWS:
        found = jit.run("topology_kernel", "changed_rows", new, old, size=len(new))
        if found is not None:
            return found
    return (new[:, 0] != old[:, 0]) | (new[:, 1] != old[:, 1]) | (new[:, 2] != old[:, 2])


@dataclass(frozen=True)
class TopologyReport:
    """What :func:`check_surface` found.

    ``ok`` holds when the surface is closed (every edge used by exactly two
    faces), consistently oriented (each use in opposite directions) and has
    no pinched vertex (the faces around every node form a single fan).
    """

    n_faces: int
    boundary_edges: int
    nonmanifold_edges: int
    misoriented_edges: int
    pinched_vertices: int

    @property
    def ok(self) -> bool:
        return (self.n_faces > 0 and self.boundary_edges == 0 and self.nonmanifold_edges == 0
                and self.misoriented_edges == 0 and self.pinched_vertices == 0)


def check_surface(faces: np.ndarray) -> TopologyReport:
    """Check that a polygon surface is a closed, oriented 2-manifold.

    Examples
    --------
    >>> cube = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4],
    ...                  [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]])
    >>> check_surface(cube).ok
    True
    >>> check_surface(cube[1:]).boundary_edges
    4
    """
    faces = np.asarray(faces, dtype=np.int64)
    m, k = faces.shape
    n_nodes = int(faces.max()) + 1 if m else 0
    tail = faces.ravel()
    head = np.roll(faces, -1, axis=1).ravel()
    directed = tail * n_nodes + head
    undirected = np.minimum(tail, head) * n_nodes + np.maximum(tail, head)
    _, uses = np.unique(undirected, return_counts=True)
    boundary = int(np.count_nonzero(uses == 1))
    nonmanifold = int(np.count_nonzero(uses > 2))
    # Among edges used twice, both uses must run in opposite directions.
    order = np.argsort(directed, kind="stable")
    sorted_keys = directed[order]
    duplicated_direction = int(np.count_nonzero(sorted_keys[1:] == sorted_keys[:-1]))
    pinched = _pinched_vertices(faces, tail, head, n_nodes, directed, order, sorted_keys)
    return TopologyReport(m, boundary, nonmanifold, duplicated_direction, pinched)


def _pinched_vertices(faces, tail, head, n_nodes, directed, order, sorted_keys) -> int:
    """Nodes whose incident faces form more than one fan."""
    m, k = faces.shape
    reverse = head * n_nodes + tail
    pos = np.searchsorted(sorted_keys, reverse)
    pos = np.minimum(pos, len(sorted_keys) - 1)
    found = sorted_keys[pos] == reverse
    # Corner c of face f (at node tail) and the corner at the same node in the
    # face across edge tail->head: that face has the edge head->tail, whose
    # corner index is order[pos]; the corner at our node is the next one.
    this_corner = np.flatnonzero(found)
    other = order[pos[found]]
    other_corner = (other // k) * k + (other % k + 1) % k
    n_corners = m * k
    graph = coo_matrix((np.ones(len(this_corner), np.int8), (this_corner, other_corner)),
                       shape=(n_corners, n_corners))
    _, fan = connected_components(graph, directed=False)
    fans = np.unique(tail * n_corners + fan)
    fans_per_node = np.bincount(fans // n_corners, minlength=n_nodes)
    return int(np.count_nonzero(fans_per_node > 1))


def triangulate(faces: np.ndarray) -> np.ndarray:
    """Split quads into two triangles along the 0-2 diagonal (triangles pass)."""
    faces = np.asarray(faces)
    if faces.shape[1] == 3:
        return faces
    return np.concatenate([faces[:, [0, 1, 2]], faces[:, [0, 2, 3]]])


def signed_volume(nodes: np.ndarray, faces: np.ndarray) -> float:
    """Volume enclosed by a closed surface; positive when normals point out.

    Examples
    --------
    >>> nodes = np.array([[x, y, z] for z in (0, 2) for y in (0, 2) for x in (0, 2)], float)
    >>> cube = np.array([[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4],
    ...                  [1, 3, 7, 5], [3, 2, 6, 7], [2, 0, 4, 6]])
    >>> signed_volume(nodes, cube)
    8.0
    """
    tri = nodes[triangulate(faces)]
    # Relative to the centroid: keeps the triple products small and exact.
    tri = tri - nodes.mean(axis=0)
    return float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0)


def surface_area(nodes: np.ndarray, faces: np.ndarray) -> float:
    """Total area of the faces."""
    tri = nodes[triangulate(faces)]
    return float(0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum())
