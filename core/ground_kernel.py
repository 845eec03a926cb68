"""Compiled chords of the ground under roofs (numba, :mod:`core.jit`).

:func:`core.ground._fill_missing` fills each column without a ground point
along chords in eight directions, each from the nearest observed column
behind it to the nearest ahead. numpy finds those steps with
:func:`core.ground.steps_to_observed`: a loop over the grid's rows, each
row a few vectorised passes, sixteen times (each direction, forwards and
backwards), then the steps of the missing columns taken from each grid.

Here each walk is one compiled pass over the grid with the same
recurrence (a column's steps are those of the column one step back, plus
one, or 0 on an observed column), holding only the rows one step back and
writing only the missing columns' steps; a direction's two walks run on two
threads. Then its chords are added into each missing column's sums, on all
cores, with numpy's operations, the directions in numpy's order and each
chord's weight from the same table (:func:`core.ground.chord_weights`): the
sums are numpy's to the last bit. The 1 km synthetic city's 1 M columns,
259 k of them missing: 0.04-0.06 s on both cores, where numpy's steps and
sums took 0.48-0.58 s on one (the same hour; 0.37 s in a run of the
pipeline on another day).
"""
from __future__ import annotations

import numpy as np

from .neighbours_kernel import compiled
from .parallel import balanced_blocks, map_blocks


def chord_sums(observed: np.ndarray, level: np.ndarray, directions: np.ndarray,
               weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For every unobserved column, in the order of their numbers: the sum
    of its chords' levels times their weights, and the sum of the weights,
    as :func:`core.ground._chord_sums`.

    A direction at a time, as numpy adds them: its two walks
    (:func:`walk_steps`), then its chords added into every column's sums
    in blocks. Only one direction's steps are held (8 bytes a missing
    column; all sixteen walks at once held 64, 320 MB for a 2 km city at
    0.5 m), and each column's sums add the directions in numpy's order.

    Parameters
    ----------
    observed : ndarray of bool (nx, ny)
    level : ndarray (nx ny,)
        The columns' levels (those of the observed ones are read).
    directions : ndarray of int (D, 2)
        As for :func:`walk_steps`.
    weight : ndarray (D, K)
        A chord's weight by direction and by the steps to its nearer end,
        less one (:func:`core.ground.chord_weights`).

    Returns
    -------
    total, weights : ndarray (M,)

    Examples
    --------
    A row of four columns with levels 1 and 4 at its ends, and one
    direction along it: the two between get the linear interpolation.

    >>> total, weights = chord_sums(np.array([[True, False, False, True]]), np.array([1.0, 0, 0, 4]),
    ...                             np.array([[0, 1]]), np.array([[1.0, 1 / 16, 1 / 81, 1 / 256]]))
    >>> (total / weights).tolist()
    [2.0, 3.0]
    """
    observed = np.ascontiguousarray(observed, dtype=np.bool_)
    directions = np.ascontiguousarray(directions, dtype=np.int64)
    missing = np.flatnonzero(~observed.ravel())
    level = np.ascontiguousarray(level, dtype=np.float64)
    weight = np.ascontiguousarray(weight, dtype=np.float64)
    total = np.zeros(len(missing))
    weights = np.zeros(len(missing))
    blocks = balanced_blocks(len(missing))
    for d in range(len(directions)):
        di, dj = int(directions[d, 0]), int(directions[d, 1])
        behind, ahead = walk_steps(observed, di, dj)
        map_blocks(lambda rows: _add_chords(behind, ahead, missing, level, observed.shape[1], di, dj, weight[d],
                                            rows.start, rows.stop, total, weights), blocks)
    return total, weights


def walk_steps(observed: np.ndarray, di: int, dj: int) -> tuple[np.ndarray, np.ndarray]:
    """Steps from every unobserved column to the nearest observed column
    behind it and ahead of it along ``(di, dj)``: the direction's two walks,
    one on each of two threads.

    Parameters
    ----------
    observed : ndarray of bool (nx, ny)
    di, dj : int
        The step: ``di`` 0 to 2; ``dj`` positive where ``di`` is 0.

    Returns
    -------
    behind, ahead : ndarray of int32 (M,)
        For the M unobserved columns in the order of their numbers (``i * ny
        + j``): :func:`core.ground.steps_to_observed` along ``(di, dj)``
        (behind) and along its reverse (ahead), -1 where the line leaves the
        grid first.

    Examples
    --------
    >>> observed = np.array([[True, False, False, True]])
    >>> [steps.tolist() for steps in walk_steps(observed, 0, 1)]
    [[1, 2], [2, 1]]
    >>> [steps.tolist() for steps in walk_steps(observed, 1, 0)]
    [[-1, -1], [-1, -1]]
    """
    if not (0 <= di <= 2) or (di == 0 and dj <= 0):
        raise ValueError(f"direction ({di}, {dj}): di 0 to 2, and dj > 0 where di is 0")
    observed = np.ascontiguousarray(observed, dtype=np.bool_)
    behind = np.empty(observed.size - int(np.count_nonzero(observed)), np.int32)
    ahead = np.empty_like(behind)
    map_blocks(lambda backwards: _walk(observed, di, dj, backwards, ahead if backwards else behind), (False, True))
    return behind, ahead


def warm_up() -> int:
    """Compile for the types :mod:`core.ground` passes."""
    total, weights = chord_sums(np.array([[True, False, False, True]]), np.array([1.0, 0, 0, 4]),
                                np.array([[0, 1]]), np.array([[1.0, 1 / 16, 1 / 81, 1 / 256]]))
    assert (total / weights).tolist() == [2.0, 3.0], (total, weights)
    observed = np.array([[True, False, False, True], [False, False, False, False], [True, True, False, True]])
    assert walk_steps(observed, 0, 1)[0].tolist() == [1, 2, -1, -1, -1, -1, 1]
    assert walk_steps(observed, 1, 0)[1].tolist() == [2, -1, 1, 1, -1, 1, -1]
    return 1


@compiled
def _walk(observed, di, dj, backwards, steps):
    """Steps along ``(di, dj)`` back to the nearest observed column (along
    its reverse if ``backwards``) of the unobserved columns, in the order of
    their numbers, into ``steps``.

    The grid's rows are passed in the walk's order (backwards: from the
    last row and column), each column's steps made from those of the column
    one step back, held in a ring of the last three rows.
    """
    nx, ny = observed.shape
    ring = np.empty((3, ny), np.int32)
    sign = -1 if backwards else 1
    at = len(steps) - 1 if backwards else 0
    for t in range(nx):
        i = nx - 1 - t if backwards else t
        row = ring[t % 3]
        for u in range(ny):
            j = ny - 1 - u if backwards else u
            if observed[i, j]:
                row[j] = 0
                continue
            # The column one step back: row t - di of the walk, column j - dj (reversed backwards).
            bj = j - sign * dj
            step = -1
            if t >= di and 0 <= bj < ny:
                back = ring[(t - di) % 3, bj]
                if back >= 0:
                    step = back + 1
            row[j] = step
            steps[at] = step  # the walk meets the unobserved columns in their order, or in reverse
            at += sign


@compiled
def _add_chords(behind, ahead, missing, level, ny, di, dj, weight, first, stop, total, weights):
    """Add the chords along ``(di, dj)`` of the missing columns ``first:stop``
    (steps ``behind`` and ``ahead``, weights by steps ``weight``) into their
    ``total`` and ``weights``: numpy's operations, in its order."""
    for m in range(first, stop):
        b, a = behind[m], ahead[m]
        if b <= 0 or a <= 0:
            continue
        i, j = missing[m] // ny, missing[m] % ny
        z_behind = level[(i - b * di) * ny + (j - b * dj)]
        z_ahead = level[(i + a * di) * ny + (j + a * dj)]
        w = weight[min(a, b) - 1]
        total[m] += w * (z_behind + (z_ahead - z_behind) * (b / (a + b)))
        weights[m] += w
