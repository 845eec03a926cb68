"""Compiled chords of the ground under roofs (numba, :mod:`core.jit`).

:func:`core.ground._fill_missing` fills each column without a ground point
along chords in eight directions, each from the nearest observed column
behind it to the nearest ahead. numpy finds those steps with
:func:`core.ground.steps_to_observed`: a loop over the grid's rows, each
row a few vectorised passes, sixteen times (each direction, forwards and
backwards), then the steps of the missing columns taken from each grid.

Here each of the sixteen walks is one compiled pass over the grid with
the same recurrence (a column's steps are those of the column one step
back, plus one, or 0 on an observed column), holding only the rows one
step back and writing only the missing columns' steps; the walks run on
all cores. Then each missing column sums its chords, the directions in
numpy's order with numpy's operations, each chord's weight from the same
table (:func:`core.ground.chord_weights`): the sums are numpy's to the last
bit. The 1 km synthetic city's 1 M columns, 259 k of them missing: 0.04 s on
both cores, where numpy's steps and sums took 0.48-0.58 s on one (the same
hour; 0.37 s in a run of the pipeline on another day).
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

    Parameters
    ----------
    observed : ndarray of bool (nx, ny)
    level : ndarray (nx ny,)
        The columns' levels (those of the observed ones are read).
    directions : ndarray of int (D, 2)
        As for :func:`chord_steps`.
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
    behind, ahead = chord_steps(observed, directions)
    missing = np.flatnonzero(~observed.ravel())
    level = np.ascontiguousarray(level, dtype=np.float64)
    weight = np.ascontiguousarray(weight, dtype=np.float64)
    total = np.empty(len(missing))
    weights = np.empty(len(missing))
    map_blocks(lambda rows: _sums(behind, ahead, missing, level, observed.shape[1], directions, weight,
                                  rows.start, rows.stop, total, weights), balanced_blocks(len(missing)))
    return total, weights


def chord_steps(observed: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Steps from every unobserved column to the nearest observed column
    behind it and ahead of it, along each direction.

    Parameters
    ----------
    observed : ndarray of bool (nx, ny)
    directions : ndarray of int (D, 2)
        Steps (di, dj), ``di`` 0 to 2; ``dj`` positive where ``di`` is 0.

    Returns
    -------
    behind, ahead : ndarray of int32 (D, M)
        For the M unobserved columns in the order of their numbers (``i * ny
        + j``): :func:`core.ground.steps_to_observed` along ``(di, dj)``
        (behind) and along its reverse (ahead), -1 where the line leaves the
        grid first.

    Examples
    --------
    >>> observed = np.array([[True, False, False, True]])
    >>> behind, ahead = chord_steps(observed, np.array([[0, 1], [1, 0]]))
    >>> behind.tolist(), ahead.tolist()
    ([[1, 2], [-1, -1]], [[2, 1], [-1, -1]])
    """
    observed = np.ascontiguousarray(observed, dtype=np.bool_)
    directions = np.ascontiguousarray(directions, dtype=np.int64)
    if len(directions) and (directions[:, 0].min() < 0 or directions[:, 0].max() > 2
                            or (directions[:, 1][directions[:, 0] == 0] <= 0).any()):
        raise ValueError(f"directions {directions.tolist()}: di 0 to 2, and dj > 0 where di is 0")
    behind = np.empty((len(directions), observed.size - int(np.count_nonzero(observed))), np.int32)
    ahead = np.empty_like(behind)
    # Sixteen walks of equal cost: one task each.
    walks = [(d, backwards) for d in range(len(directions)) for backwards in (False, True)]
    map_blocks(lambda walk: _walk(observed, directions[walk[0], 0], directions[walk[0], 1], walk[1],
                                  (ahead if walk[1] else behind)[walk[0]]), walks)
    return behind, ahead


def warm_up() -> int:
    """Compile for the types :mod:`core.ground` passes."""
    total, weights = chord_sums(np.array([[True, False, False, True]]), np.array([1.0, 0, 0, 4]),
                                np.array([[0, 1]]), np.array([[1.0, 1 / 16, 1 / 81, 1 / 256]]))
    assert (total / weights).tolist() == [2.0, 3.0], (total, weights)
    observed = np.array([[True, False, False, True], [False, False, False, False], [True, True, False, True]])
    behind, ahead = chord_steps(observed, np.array([[0, 1], [1, 0], [1, 1], [2, -1]]))
    assert behind[0].tolist() == [1, 2, -1, -1, -1, -1, 1] and ahead[1].tolist() == [2, -1, 1, 1, -1, 1, -1], \
        (behind, ahead)
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
def _sums(behind, ahead, missing, level, ny, directions, weight, first, stop, total, weights):
    """:func:`chord_sums` of the missing columns ``first:stop``."""
    for m in range(first, stop):
        i, j = missing[m] // ny, missing[m] % ny
        t, w_sum = 0.0, 0.0
        for d in range(len(directions)):
            b, a = behind[d, m], ahead[d, m]
            if b <= 0 or a <= 0:
                continue
            di, dj = directions[d, 0], directions[d, 1]
            z_behind = level[(i - b * di) * ny + (j - b * dj)]
            z_ahead = level[(i + a * di) * ny + (j + a * dj)]
            w = weight[d, min(a, b) - 1]
            t += w * (z_behind + (z_ahead - z_behind) * (b / (a + b)))
            w_sum += w
        total[m], weights[m] = t, w_sum
