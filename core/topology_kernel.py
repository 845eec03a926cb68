"""Compiled selections of :mod:`core.topology` (numba, :mod:`core.jit`).

Every quality-controlled step asks which nodes moved
(:func:`core.topology.changed_rows`) and which faces touch them
(:func:`core.topology.touching`), on the whole model, pass after pass: on
the 1 km synthetic city (5 M nodes, 4.9 M quads), 1.5 s in all. numpy
writes each as a few whole-array passes (a gather per corner column, a
comparison per coordinate); here each is one pass on all cores. The answers
are booleans, the same either way.
"""
from __future__ import annotations

import numpy as np

from .neighbours_kernel import compiled
from .parallel import balanced_blocks, map_blocks


def touching(marked: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Which faces have a corner at a marked node (:func:`core.topology.touching`).

    Examples
    --------
    >>> touching(np.array([False, True, False, False]), np.array([[0, 1, 2], [0, 2, 3]])).tolist()
    [True, False]
    """
    marked = np.ascontiguousarray(marked, dtype=np.bool_)
    faces = np.ascontiguousarray(faces)
    hit = np.empty(len(faces), dtype=np.bool_)
    map_blocks(lambda rows: _touching(marked, faces, rows.start, rows.stop, hit), balanced_blocks(len(faces)))
    return hit


def changed_rows(new: np.ndarray, old: np.ndarray) -> np.ndarray:
    """Rows of two (N, 3) tables that differ (:func:`core.topology.changed_rows`).

    Examples
    --------
    >>> changed_rows(np.array([[0.0, 1, 2], [3, 4, 5]]), np.array([[0.0, 1, 2], [3, 4, 6]])).tolist()
    [False, True]
    """
    new = np.ascontiguousarray(new, dtype=np.float64)
    old = np.ascontiguousarray(old, dtype=np.float64)
    changed = np.empty(len(new), dtype=np.bool_)
    map_blocks(lambda rows: _changed(new, old, rows.start, rows.stop, changed), balanced_blocks(len(new)))
    return changed


def warm_up() -> int:
    """Compile for the tables the pipeline passes: quads and triangles of
    64-bit and 32-bit node numbers, float64 positions."""
    marked = np.array([False, True, False, False])
    for dtype in (np.int64, np.int32):
        for faces in ([[0, 1, 2], [0, 2, 3]], [[0, 1, 2, 3], [0, 2, 3, 0]]):
            assert touching(marked, np.array(faces, dtype=dtype)).tolist() == [True, False]
    assert changed_rows(np.zeros((2, 3)), np.eye(2, 3)).tolist() == [True, True]
    return 1


@compiled
def _touching(marked, faces, start, stop, hit):
    """Rows ``start:stop`` of :func:`touching`."""
    corners = faces.shape[1]
    for m in range(start, stop):
        found = False
        for k in range(corners):
            found |= marked[faces[m, k]]
        hit[m] = found


@compiled
def _changed(new, old, start, stop, changed):
    """Rows ``start:stop`` of :func:`changed_rows` (NaN differs from all, as ``!=``)."""
    for j in range(start, stop):
        changed[j] = new[j, 0] != old[j, 0] or new[j, 1] != old[j, 1] or new[j, 2] != old[j, 2]
