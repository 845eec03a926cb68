"""Well-composed voxel labels, so every surface is a closed 2-manifold (§3.3).

A voxel set has a manifold boundary exactly when it is *well-composed*: no
two of its voxels meet only along an edge (four faces of the surface on one
edge) or only at a vertex (two cones meeting at a point), and the same holds
for its complement. The paper's quad surfaces need that for every region:
each building block, the ground and the air.

The repair only ever turns air into building, the smallest change that keeps
the data (a building grows by a voxel where it touched itself or the ground
diagonally) and keeps the ground a height field:

* the ground, a height field, is well-composed when its level map has no
  diagonal 2 x 2 pattern (:func:`repair_height_field`);
* then making both the building set B and the solid set S = B + ground
  well-composed makes every block (a 6-connected part of B, and B is
  well-composed so no two blocks touch diagonally), the ground and the air
  (the complement of S) well-composed.
"""
from __future__ import annotations

import itertools
from typing import Callable

import numpy as np

from .classify import AIR, BUILDING, enclose_air
from .errors import Cancelled

#: Corners of a 2 x 2 x 2 cube, bit b of a cube code is corner CORNERS[b].
CORNERS = np.array(list(itertools.product((0, 1), repeat=3)), dtype=np.int64)
_OPPOSITE = [(a, b) for a in range(8) for b in range(a + 1, 8) if np.all(CORNERS[a] + CORNERS[b] == 1)]
#: Cube codes where the set is two opposite corners only (vertex-critical).
_PAIR_CODES = np.array([(1 << a) | (1 << b) for a, b in _OPPOSITE], dtype=np.uint8)
#: Cube codes where the complement is two opposite corners only.
_HOLE_CODES = np.array([0xFF ^ c for c in _PAIR_CODES], dtype=np.uint8)


def repair_height_field(top_k: np.ndarray, max_iterations: int = 100) -> np.ndarray:
    """Raise columns until no 2 x 2 window has a diagonal pattern.

    A window whose two diagonal columns are both higher than both
    anti-diagonal ones makes the ground meet itself along an edge at every
    level in between; raising the higher anti-diagonal column to the lower
    diagonal level removes it.

    Examples
    --------
    >>> repair_height_field(np.array([[3, 1], [1, 3]]))
    array([[3, 1],
           [3, 3]])
    """
    top_k = top_k.copy()
    # Window corners: a=(i,j) b=(i+1,j) c=(i+1,j+1) d=(i,j+1). For each
    # diagonal, the offsets of its two corners and of the anti-diagonal ones.
    diagonals = (((0, 0), (1, 1), (1, 0), (0, 1)),
                 ((1, 0), (0, 1), (0, 0), (1, 1)))
    nx, ny = top_k.shape
    for _ in range(max_iterations):
        changed = False
        for p, q, r, s in diagonals:
            def corner(o: tuple[int, int]) -> np.ndarray:
                return top_k[o[0]:nx - 1 + o[0], o[1]:ny - 1 + o[1]]
            low_diagonal = np.minimum(corner(p), corner(q))
            bad = low_diagonal > np.maximum(corner(r), corner(s))
            if not bad.any():
                continue
            i, j = np.nonzero(bad)
            # Raise whichever anti-diagonal column is higher: fewer new ground voxels.
            raise_r = corner(r)[i, j] >= corner(s)[i, j]
            ti = i + np.where(raise_r, r[0], s[0])
            tj = j + np.where(raise_r, r[1], s[1])
            np.maximum.at(top_k, (ti, tj), low_diagonal[i, j])
            changed = True
        if not changed:
            return top_k
    raise RuntimeError("height-field repair did not converge")  # pragma: no cover


def make_well_composed(labels: np.ndarray, max_iterations: int = 200,
                       is_cancelled: Callable[[], bool] | None = None) -> int:
    """Turn air voxels into building until buildings and solids are well-composed.

    Air pockets cut off by the filling become building too, so the air stays
    one volume.

    Works in place on ``labels`` (``GROUND``/``BUILDING``/``AIR``); the ground
    must already be a repaired height field.

    Returns
    -------
    int
        Number of air voxels turned into building.

    Examples
    --------
    Two building voxels meeting along an edge get a third one:

    >>> lab = np.full((2, 2, 3), AIR, np.uint8); lab[:, :, 0] = 1
    >>> lab[0, 0, 1] = lab[1, 1, 1] = BUILDING
    >>> make_well_composed(lab)
    1
    """
    added = 0
    box = tuple(slice(0, n) for n in labels.shape)
    for _ in range(max_iterations):
        if is_cancelled is not None and is_cancelled():
            raise Cancelled()
        sub = labels[box]
        targets = _critical_air_cells(sub)
        if len(targets) == 0:
            # Filling may have cut pockets off the air: they are enclosed, so
            # building (paper §2), and that may create new critical patterns.
            enclosed = enclose_air(labels)
            if enclosed == 0:
                return added
            added += enclosed
            box = tuple(slice(0, n) for n in labels.shape)
            continue
        targets += np.array([s.start for s in box])
        targets = np.unique(targets, axis=0)
        labels[targets[:, 0], targets[:, 1], targets[:, 2]] = BUILDING
        added += len(targets)
        # Only the neighbourhood of what changed can hold new critical patterns.
        lo = np.maximum(targets.min(axis=0) - 2, 0)
        hi = np.minimum(targets.max(axis=0) + 3, labels.shape)
        box = tuple(slice(int(a), int(b)) for a, b in zip(lo, hi))
    raise RuntimeError("well-composed repair did not converge")  # pragma: no cover


def _critical_air_cells(labels: np.ndarray) -> np.ndarray:
    """Air cells whose conversion to building resolves each critical pattern."""
    air = labels == AIR
    building = labels == BUILDING
    out = []
    for field in (building, ~air):  # B, then S = building + ground
        out.extend(_edge_fixes(field, air))
        out.extend(_vertex_fixes(field, air))
    if not out:
        return np.zeros((0, 3), dtype=np.int64)
    return np.concatenate(out)


def _edge_fixes(field: np.ndarray, air: np.ndarray) -> list[np.ndarray]:
    """For each edge-critical 2 x 2 window of ``field``, one air cell to fill."""
    fixes = []
    for p, q in ((0, 1), (0, 2), (1, 2)):
        def cell(dp: int, dq: int, arr: np.ndarray) -> np.ndarray:
            sl = [slice(None)] * 3
            sl[p] = slice(dp, arr.shape[p] - 1 + dp)
            sl[q] = slice(dq, arr.shape[q] - 1 + dq)
            return arr[tuple(sl)]
        a, b, c, d = (cell(0, 0, field), cell(1, 0, field), cell(1, 1, field), cell(0, 1, field))
        # Diagonal a-c in the set, b and d out: fill b or d; and the mirror case.
        for inside, (o1, o2) in (((a & c & ~b & ~d), ((1, 0), (0, 1))),
                                 ((b & d & ~a & ~c), ((0, 0), (1, 1)))):
            idx = np.argwhere(inside)
            if len(idx) == 0:
                continue
            first = idx.copy()
            first[:, p] += o1[0]
            first[:, q] += o1[1]
            second = idx.copy()
            second[:, p] += o2[0]
            second[:, q] += o2[1]
            first_is_air = air[first[:, 0], first[:, 1], first[:, 2]]
            fixes.append(np.where(first_is_air[:, None], first, second))
    return fixes


def _vertex_fixes(field: np.ndarray, air: np.ndarray) -> list[np.ndarray]:
    """For each vertex-critical 2 x 2 x 2 cube of ``field``, one air cell to fill."""
    nx, ny, nz = field.shape
    code = np.zeros((nx - 1, ny - 1, nz - 1), dtype=np.uint8)
    for bit, (di, dj, dk) in enumerate(CORNERS):
        code |= field[di:nx - 1 + di, dj:ny - 1 + dj, dk:nz - 1 + dk].astype(np.uint8) << bit
    fixes = []
    critical = np.isin(code, _PAIR_CODES) | np.isin(code, _HOLE_CODES)
    idx = np.argwhere(critical)
    if len(idx) == 0:
        return fixes
    # Candidate corners: the cube's air corners, in a fixed order; take the first.
    corner_cells = idx[:, None, :] + CORNERS[None, :, :]
    corner_air = air[corner_cells[..., 0], corner_cells[..., 1], corner_cells[..., 2]]
    has_air = corner_air.any(axis=1)
    choice = np.argmax(corner_air, axis=1)
    fixes.append(corner_cells[np.arange(len(idx)), choice][has_air])
    return fixes
