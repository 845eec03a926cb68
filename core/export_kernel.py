"""Compiled entity search of the gmsh export (numba, :mod:`core.jit`).

The gmsh file's entities must be connected (:func:`core.export._msh_topology`):
every interface is split into patches of faces linked through the nodes they
share, every region into shells of the patches' sides. The numpy twin
(:func:`core.export._msh_entities`) builds a sparse graph of faces and
(interface, node) pairs and scipy labels its connected components, then
gathers every corner's coordinates for the patches' boxes: 2.6-3.7 s of the
1 km synthetic city's export. Here each group's items are visited in turn,
joining through the nodes they meet (a union-find), and the boxes are one
pass: 0.75-0.85 s, the same entities to the bit.
"""
from __future__ import annotations

import numpy as np

from .blocks_kernel import join, numbered_sets
from .neighbours_kernel import compiled


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
    return _entities(faces, np.ascontiguousarray(which, dtype=np.int64),
                     np.ascontiguousarray(side_rank, dtype=np.int64), np.ascontiguousarray(world, dtype=np.float64))


def warm_up() -> int:
    """Compile for the arrays the export passes (the doctest's entities)."""
    faces, world = np.array([[0, 1, 4, 3], [1, 2, 5, 4], [2, 6, 7, 5]]), np.arange(24.0).reshape(8, 3)
    shell = msh_entities(faces, np.array([0, 0, 1]), np.array([[0, 1], [0, 1]]), world)[4]
    assert shell.tolist() == [0, 0, 1, 1], shell
    return 1


@compiled
def _entities(faces, which, side_rank, world):
    """:func:`msh_entities`."""
    n_nodes = len(world)
    # Patches: the faces by interface (a stable counting sort), each joining
    # the part of the last face of its interface at each of its corners.
    face_order, _ = _counting_order(which, len(side_rank))
    sets = np.arange(len(faces) + 1)
    label = _grouped_parts(faces, face_order, sets, sets[:-1], which[face_order], n_nodes)
    n_patches = 0
    for i in range(len(label)):
        n_patches = max(n_patches, label[i] + 1)
    first_face = np.empty(n_patches, np.int64)
    patch = np.empty(len(faces), np.int64)
    found = 0
    for i in range(len(label)):
        f = face_order[i]
        patch[f] = label[i]
        if label[i] == found:  # parts are numbered by their first face
            first_face[found] = f
            found += 1
    order, bounds = _counting_order(patch, n_patches)
    # Shells: the sides of the patches (side s of patch p is item s P + p)
    # that bound a region, by region and then first face, each joining the
    # part of the last side of its region at each node of its patch.
    key = np.empty(2 * n_patches, np.int64)
    n_items = 0
    for s in range(2):
        for p in range(n_patches):
            rank = side_rank[which[first_face[p]], s]
            if rank >= 0:
                key[n_items] = rank * len(faces) + first_face[p]
                n_items += 1
    items = np.empty(n_items, np.int64)
    n_items = 0
    for s in range(2):
        for p in range(n_patches):
            if side_rank[which[first_face[p]], s] >= 0:
                items[n_items] = s * n_patches + p
                n_items += 1
    items = items[np.argsort(key[:n_items], kind="mergesort")]
    item_patch = items % n_patches
    item_rank = np.empty(n_items, np.int64)
    for i in range(n_items):
        item_rank[i] = side_rank[which[first_face[item_patch[i]]], items[i] // n_patches]
    shell = _grouped_parts(faces, order, bounds, item_patch, item_rank, n_nodes)
    # The patches' boxes, in the faces' order (their nodes' order, near
    # enough), signed zeros made positive as the numpy twin's.
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
    lower += 0.0
    upper += 0.0
    return first_face, order, bounds, items, shell, lower, upper


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
def _grouped_parts(faces, member, start, item_set, item_group, n_nodes):
    """The parts of items linked when of the same group and on a common node:
    item ``i``'s nodes are the corners of the faces ``member[start[s]:start[s
    + 1]]``, ``s = item_set[i]``; the items of a group are consecutive. Parts
    are numbered in the order of their first item (:func:`link_parts`)."""
    parent = np.arange(len(item_set))
    node_group = np.full(n_nodes, -1, np.int64)  # the last group met at each node, and its item
    node_item = np.zeros(n_nodes, np.int64)
    for i in range(len(item_set)):
        group = item_group[i]
        for m in range(start[item_set[i]], start[item_set[i] + 1]):
            for c in range(faces.shape[1]):
                v = faces[member[m], c]
                if node_group[v] != group:
                    node_group[v] = group
                    node_item[v] = i
                elif node_item[v] != i:
                    join(parent, i, node_item[v])
    return numbered_sets(parent, 0)[0]
