"""Compiled entity search of the gmsh export (numba, :mod:`core.jit`).

The gmsh file's entities must be connected (:func:`core.export._msh_topology`):
every interface is split into patches of faces linked through the nodes they
share, every region into shells of the patches' sides. The numpy twin
(:func:`core.export._msh_entities`) builds a sparse graph of faces and
(interface, node) pairs and scipy labels its connected components, then
gathers every corner's coordinates for the patches' boxes: 2.6-3.7 s of the
1 km synthetic city's export. Here each group's items are visited in turn,
joining through the nodes they meet (a union-find), runs of whole groups
on the threads side by side, and the boxes are one pass beside the shells':
0.6-0.74 s, the same entities to the bit.
"""
from __future__ import annotations

import numpy as np

from .blocks_kernel import join, numbered_sets
from .neighbours_kernel import compiled
from .parallel import map_blocks, thread_count


def msh_entities(faces: np.ndarray, which: np.ndarray, side_rank: np.ndarray,
                 world: np.ndarray) -> tuple[np.ndarray, ...]:
    """The gmsh entities' patches, shells and patch boxes, as
    :func:`core.export._msh_entities` (the numpy twin) finds them.

    Instead of a graph of faces and (interface, node) pairs, each interface's
    faces are visited in turn, and a face meeting a node that a face of the
    same interface met before joins its part: a node remembers the last
    interface that met it and the face that did. The shells are found alike,
    the patches' sides of each region in turn, over their patches' faces.
    The numbering is the twin's: patches by interface and then first face,
    shells by region and then first item.

    Examples
    --------
    Two squares of interface 0 sharing an edge, one of interface 1 beside
    them, each patch between regions 0 and 1:

    >>> faces = np.array([[0, 1, 4, 3], [1, 2, 5, 4], [2, 6, 7, 5]])
    >>> world = np.arange(24.0).reshape(8, 3)
    >>> first_face, order, bounds, items, shell, lower, upper = msh_entities(
    ...     faces, np.array([0, 0, 1]), np.array([[0, 1], [0, 1]]), world)
    >>> first_face.tolist(), bounds.tolist(), shell.tolist()
    ([0, 2], [0, 2, 3], [0, 0, 1, 1])
    """
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    which = np.ascontiguousarray(which, dtype=np.int64)
    side_rank = np.ascontiguousarray(side_rank, dtype=np.int64)
    world = np.ascontiguousarray(world, dtype=np.float64)
    # Patches: the faces by interface (a stable counting sort), each joining
    # the part of the last face of its interface at each of its corners.
    face_order, _ = _counting_order(which, len(side_rank))
    sets = np.arange(len(faces) + 1)
    label = _grouped_parts(faces, face_order, sets, sets[:-1], which[face_order], len(world))
    patch, first_face = _numbered_patches(label, face_order)
    order, bounds = _counting_order(patch, len(first_face))
    items, item_patch, item_rank = _items(first_face, which, side_rank, len(faces))
    # The shells and the boxes share nothing: each on a thread of its own.
    shell, (lower, upper) = map_blocks(lambda task: task(), (
        lambda: _grouped_parts(faces, order, bounds, item_patch, item_rank, len(world), 1),
        lambda: _boxes(faces, patch, world, len(first_face))))
    return first_face, order, bounds, items, shell, lower, upper


def _grouped_parts(faces: np.ndarray, member: np.ndarray, start: np.ndarray, item_set: np.ndarray,
                   item_group: np.ndarray, n_nodes: int, threads: int | None = None) -> np.ndarray:
    """The parts of items linked when of the same group and on a common node:
    item ``i``'s nodes are the corners of the faces ``member[start[s]:start[s
    + 1]]``, ``s = item_set[i]``; the items of a group are consecutive. Parts
    are numbered in the order of their first item (int32).

    The groups share no part, so runs of whole groups are joined on the
    threads side by side (``threads``, else every one), each with a table
    of the nodes of its own (the 1 km city's patches: 0.3 s on one core).
    """
    parent = np.arange(len(item_set))
    runs = _group_runs(start, item_set, item_group, threads or thread_count())
    map_blocks(lambda run: _join_groups(faces, member, start, item_set, item_group, n_nodes, parent,
                                        run.start, run.stop), runs)
    return numbered_sets(parent, 0)[0]


def warm_up() -> int:
    """Compile for the arrays the export passes (the doctest's entities)."""
    faces, world = np.array([[0, 1, 4, 3], [1, 2, 5, 4], [2, 6, 7, 5]]), np.arange(24.0).reshape(8, 3)
    shell = msh_entities(faces, np.array([0, 0, 1]), np.array([[0, 1], [0, 1]]), world)[4]
    assert shell.tolist() == [0, 0, 1, 1], shell
    return 1


@compiled
def _numbered_patches(label, face_order):
    """The patch of every face from the parts of the faces in interface
    order, and every patch's first face (parts are numbered by it)."""
    n_patches = 0
    for i in range(len(label)):
        n_patches = max(n_patches, label[i] + 1)
    first_face = np.empty(n_patches, np.int64)
    patch = np.empty(len(label), np.int64)
    found = 0
    for i in range(len(label)):
        f = face_order[i]
        patch[f] = label[i]
        if label[i] == found:
            first_face[found] = f
            found += 1
    return patch, first_face


@compiled
def _items(first_face, which, side_rank, n_faces):
    """The sides of the patches (side s of patch p is item s P + p) that
    bound a region, by region and then first face; each one's patch and
    region rank."""
    n_patches = len(first_face)
    key = np.empty(2 * n_patches, np.int64)
    items = np.empty(2 * n_patches, np.int64)
    n_items = 0
    for s in range(2):
        for p in range(n_patches):
            rank = side_rank[which[first_face[p]], s]
            if rank >= 0:
                key[n_items] = rank * n_faces + first_face[p]
                items[n_items] = s * n_patches + p
                n_items += 1
    items = items[:n_items][np.argsort(key[:n_items], kind="mergesort")]
    item_patch = np.empty(n_items, np.int64)
    item_rank = np.empty(n_items, np.int64)
    for i in range(n_items):
        item_patch[i] = items[i] % n_patches
        item_rank[i] = side_rank[which[first_face[item_patch[i]]], items[i] // n_patches]
    return items, item_patch, item_rank


@compiled
def _boxes(faces, patch, world, n_patches):
    """Every patch's box, in the faces' order (their nodes' order, near
    enough), signed zeros made positive as the numpy twin's."""
    lower = np.full((n_patches, 3), np.inf)
    upper = np.full((n_patches, 3), -np.inf)
    for f in range(len(faces)):
        p = patch[f]
        for c in range(faces.shape[1]):
            v = faces[f, c]
            for a in range(3):
                x = world[v, a]
                if x < lower[p, a]:
                    lower[p, a] = x
                if x > upper[p, a]:
                    upper[p, a] = x
    return lower + 0.0, upper + 0.0


@compiled
def _counting_order(key, n_keys):
    """``np.argsort(key, kind="stable")`` of keys ``0..n_keys-1``, and where
    each key's run starts in it (``n_keys + 1`` bounds)."""
    start = np.zeros(n_keys + 1, np.int64)
    for i in range(len(key)):
        start[key[i] + 1] += 1
    for k in range(n_keys):
        start[k + 1] += start[k]
    order = np.empty(len(key), np.int64)
    slot = start[:-1].copy()
    for i in range(len(key)):
        order[slot[key[i]]] = i
        slot[key[i]] += 1
    return order, start


@compiled
def _join_groups(faces, member, start, item_set, item_group, n_nodes, parent, first, stop):
    """:func:`_grouped_parts`'s joins of the items ``first..stop-1`` (whole groups) into ``parent``."""
    node_group = np.full(n_nodes, -1, np.int64)  # the last group met at each node, and its item
    node_item = np.zeros(n_nodes, np.int64)
    for i in range(first, stop):
        group = item_group[i]
        for m in range(start[item_set[i]], start[item_set[i] + 1]):
            for c in range(faces.shape[1]):
                v = faces[member[m], c]
                if node_group[v] != group:
                    node_group[v] = group
                    node_item[v] = i
                elif node_item[v] != i:
                    join(parent, i, node_item[v])


@compiled
def _group_runs_bounds(start, item_set, item_group, parts):
    """Where runs of whole groups of about equal faces begin, and end."""
    n = len(item_set)
    weight = np.empty(n + 1, np.int64)  # faces of the items before each
    weight[0] = 0
    for i in range(n):
        weight[i + 1] = weight[i] + start[item_set[i] + 1] - start[item_set[i]]
    bounds = [0]
    for k in range(1, parts):
        i = max(bounds[-1], np.searchsorted(weight, weight[n] * k // parts))
        while 0 < i < n and item_group[i] == item_group[i - 1]:  # to the group's end
            i += 1
        if i < n:
            bounds.append(i)
    bounds.append(n)
    return np.array(bounds)


def _group_runs(start: np.ndarray, item_set: np.ndarray, item_group: np.ndarray, parts: int) -> list[slice]:
    bounds = _group_runs_bounds(start, item_set, item_group, parts).tolist()
    return [slice(a, b) for a, b in zip(bounds, bounds[1:]) if b > a]
