"""Compiled per-block sums of the measures (numba, :mod:`core.jit`).

:func:`core.measure.measure_blocks` splits the block faces into triangles,
orients them out of their block, and sums per block the triangles' signed
volumes to a reference point, their areas, and the areas of the roof and
facade triangles: a table of the triangles, one of their first corners and
some ten ``bincount`` passes, 0.8 of its 1.1 s on the 1 km synthetic city
(4.8 M triangles). Here two passes over the faces make the same sums: the
triangles are taken from each face and its split as they are needed, in the
numpy code's order (the faces outward from their block first, then those
inward, reversed), and each sum is added in that order with the same
operations, so the sums are ``bincount``'s to the last bit.

The blocks are shared out among the threads in ranges of about as many
faces: each thread runs both passes over all the faces and sums those of
its own blocks, each block's in the same order as one pass would. On the
1 km synthetic city the sums ran on one core alone, 0.22-0.24 s; with them
on both, the measures took 0.28-0.32 s instead of 0.36-0.51 s.
"""
from __future__ import annotations

import numpy as np

from .neighbours_kernel import compiled, length
from .parallel import map_blocks, thread_count

#: The corners of a quad's two triangles, split along 0-2 or along 1-3 (core.quality.split_along).
_CORNERS = np.array([[[0, 1, 2], [0, 2, 3]], [[1, 2, 3], [1, 3, 0]]], dtype=np.int64)


def triangle_sums(nodes: np.ndarray, quads: np.ndarray, use_second: np.ndarray, outward: np.ndarray,
                  owner: np.ndarray, n_blocks: int, limit: float) -> tuple[np.ndarray, ...]:
    """Per-block sums of the triangles of the block faces, as
    :func:`core.measure.measure_blocks` makes them.

    Parameters
    ----------
    nodes : ndarray (N, 3)
    quads : ndarray of int (B, 4)
        The block faces, as the model orients them.
    use_second : ndarray of bool (B,)
        Faces split along their diagonal 1-3 (else 0-2).
    outward : ndarray of bool (B,)
        Faces oriented out of their block (the others are reversed).
    owner : ndarray of int (B,)
        The block of each face, outward faces first then the others, each
        in their order (:meth:`core.surface.SurfaceModel.block_faces`).
    n_blocks : int
    limit : float
        Sine of the facade tilt: a triangle is a roof where its normal's z
        is at least that, a facade where its absolute value is below it.

    Returns
    -------
    six_volume, area, roof_area, facade_area : ndarray (n_blocks + 1,)
        Sums over each block's triangles (six times the volume).

    Examples
    --------
    A unit cube's six faces, oriented out of block 1:

    >>> nodes = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    >>> quads = np.array([[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]])
    >>> n = len(quads)
    >>> sums = triangle_sums(nodes, quads, np.zeros(n, bool), np.ones(n, bool), np.ones(n, np.int64), 1, 0.5)
    >>> [round(float(s[1]), 9) for s in sums]  # six times the volume, area, roof, facades
    [6.0, 6.0, 1.0, 4.0]
    """
    nodes = np.ascontiguousarray(nodes, dtype=np.float64)
    sums = np.zeros((4, n_blocks + 1))
    reference = np.zeros((n_blocks + 1, 3))
    count = np.zeros(n_blocks + 1, dtype=np.int64)
    # The faces in the triangles' order: those outward from their block, then the others.
    faces = np.concatenate([np.flatnonzero(outward), np.flatnonzero(~outward)])
    ranges = block_ranges(owner, n_blocks, thread_count())
    map_blocks(lambda blocks: _references(nodes, quads, use_second, outward, faces, owner, blocks[0], blocks[1],
                                          reference, count), ranges)
    # As numpy: the sums over a block's first corners, over at least one.
    reference /= np.maximum(count, 1)[:, None]
    map_blocks(lambda blocks: _sums(nodes, quads, use_second, outward, faces, owner, blocks[0], blocks[1],
                                    reference, float(limit), sums), ranges)
    return sums[0], sums[1], sums[2], sums[3]


def block_ranges(owner: np.ndarray, n_blocks: int, parts: int) -> list[tuple[int, int]]:
    """Up to ``parts`` consecutive ranges ``(first, stop)`` of the block
    numbers ``0..n_blocks``, each holding about as many of the faces
    ``owner`` lists; none empty of blocks.

    Examples
    --------
    >>> block_ranges(np.array([1, 1, 1, 1, 2, 3]), 3, 2)
    [(0, 2), (2, 4)]
    >>> block_ranges(np.array([1, 1, 2]), 2, 8)  # fewer ranges than parts, none without a block
    [(0, 2), (2, 3)]
    """
    faces_before = np.concatenate([[0], np.cumsum(np.bincount(owner, minlength=n_blocks + 1))])
    cuts = np.searchsorted(faces_before, np.arange(1, parts) * (len(owner) / parts), side="right")
    bounds = np.unique(np.concatenate([[0], np.clip(cuts, 1, n_blocks), [n_blocks + 1]]))
    return [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]


def warm_up() -> int:
    """Compile for the types :mod:`core.measure` passes."""
    nodes = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    quads = np.array([[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]])
    n = len(quads)
    for dtype in (np.int64, np.int32):
        sums = triangle_sums(nodes, quads.astype(dtype), np.zeros(n, bool), np.ones(n, bool),
                             np.ones(n, dtype), 1, 0.5)
        assert [round(float(s[1]), 9) for s in sums] == [6.0, 6.0, 1.0, 4.0], sums
    return 1


@compiled
def _corner(quads, use_second, outward, face, triangle, k):
    """Node of corner ``k`` of triangle ``triangle`` (0 or 1) of block face
    ``face``, oriented out of its block (an inward face's triangles reversed)."""
    c = k if outward[face] else 2 - k
    return quads[face, _CORNERS[1 if use_second[face] else 0, triangle, c]]


@compiled
def _references(nodes, quads, use_second, outward, faces, owner, first, stop, reference, count):
    """Sum each block's triangles' first corners into ``reference`` and count
    its triangles, in the triangles' order (``faces`` in turn, ``owner``
    theirs), for the blocks ``first`` to ``stop - 1``."""
    for m in range(len(faces)):
        face, block = faces[m], owner[m]
        if block < first or block >= stop:
            continue
        for triangle in range(2):
            a = _corner(quads, use_second, outward, face, triangle, 0)
            count[block] += 1
            reference[block, 0] += nodes[a, 0]
            reference[block, 1] += nodes[a, 1]
            reference[block, 2] += nodes[a, 2]


@compiled
def _sums(nodes, quads, use_second, outward, faces, owner, first, stop, reference, limit, sums):
    """Add each triangle's six times signed volume to its block's reference,
    its area, and its area again where it is a roof or a facade, into
    ``sums`` (4, n + 1), with :func:`core.measure.measure_blocks`'s operations,
    for the blocks ``first`` to ``stop - 1``."""
    for m in range(len(faces)):
        face, block = faces[m], owner[m]
        if block < first or block >= stop:
            continue
        cx, cy, cz = reference[block, 0], reference[block, 1], reference[block, 2]
        for triangle in range(2):
            a = _corner(quads, use_second, outward, face, triangle, 0)
            b = _corner(quads, use_second, outward, face, triangle, 1)
            c = _corner(quads, use_second, outward, face, triangle, 2)
            ux, uy, uz = nodes[b, 0] - nodes[a, 0], nodes[b, 1] - nodes[a, 1], nodes[b, 2] - nodes[a, 2]
            vx, vy, vz = nodes[c, 0] - nodes[a, 0], nodes[c, 1] - nodes[a, 1], nodes[c, 2] - nodes[a, 2]
            tx, ty, tz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
            area = 0.5 * length(tx, ty, tz)
            r0x, r0y, r0z = nodes[a, 0] - cx, nodes[a, 1] - cy, nodes[a, 2] - cz
            r1x, r1y, r1z = nodes[b, 0] - cx, nodes[b, 1] - cy, nodes[b, 2] - cz
            r2x, r2y, r2z = nodes[c, 0] - cx, nodes[c, 1] - cy, nodes[c, 2] - cz
            wx, wy, wz = r1y * r2z - r1z * r2y, r1z * r2x - r1x * r2z, r1x * r2y - r1y * r2x
            six_volume = (r0x * wx + r0z * wz) + r0y * wy  # core.vectors.dot: x and z first
            nz = tz / (2 * area) if area > 0 else 0.0
            sums[0, block] += six_volume
            sums[1, block] += area
            # numpy adds area * mask: area or zero, the same sums.
            sums[2, block] += area * (1.0 if nz >= limit else 0.0)
            sums[3, block] += area * (1.0 if abs(nz) < limit else 0.0)
