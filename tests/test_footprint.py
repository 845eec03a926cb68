"""Footprints (core.footprint): the outline of each block's columns against shapely's union of their squares."""

import numpy as np
import pytest
import shapely

from core.footprint import column_outlines


def union_of_squares(columns, corner, size):
    """The reference: shapely's union of the column squares, the largest part of a MultiPolygon."""
    x = corner[0] + columns[:, 0] * size
    y = corner[1] + columns[:, 1] * size
    shape = shapely.union_all(shapely.box(x, y, x + size, y + size))
    if shape.geom_type == "MultiPolygon":
        shape = max(shape.geoms, key=lambda part: part.area)
    return shape


def blob(rng, n, start):
    """``n`` distinct columns grown from ``start`` by random steps to a side (4-connected)."""
    cells = {start}
    frontier = [start]
    while len(cells) < n:
        i, j = frontier[rng.integers(len(frontier))]
        di, dj = ((1, 0), (-1, 0), (0, 1), (0, -1))[rng.integers(4)]
        cell = (i + di, j + dj)
        if cell not in cells:
            cells.add(cell)
            frontier.append(cell)
    return np.array(sorted(cells))


@pytest.mark.parametrize("seed", range(6))
def test_random_blocks_are_the_union_of_their_squares(seed):
    # Forty blobs of 1 to 300 columns, some overlapping in plan (blocks one
    # above the other), with courtyards, corners that pinch and parts of
    # one column: the same area as shapely's union, valid polygons.
    rng = np.random.default_rng(seed)
    ids = rng.permutation(np.arange(1, 41)) * 3  # not 1..n, not in order
    columns = []
    for block in ids:
        cells = blob(rng, int(rng.integers(1, 300)), tuple(rng.integers(0, 60, 2)))
        columns.append(np.column_stack([np.full(len(cells), block), cells]))
    columns = np.concatenate(columns)
    corner, size = np.array([2.5e5, 5.1e6]), 0.5
    outlines = column_outlines(columns, ids, corner, size)
    assert len(outlines) == len(ids)
    for block, outline in zip(ids, outlines):
        wanted = union_of_squares(columns[columns[:, 0] == block, 1:], corner, size)
        assert outline.geom_type == "Polygon" and outline.is_valid
        assert shapely.equals(outline, wanted), block
        assert outline.area == pytest.approx(wanted.area, rel=1e-12)


def test_a_courtyard_and_a_pinch():
    # A 5 x 5 square with two courtyards of one column that touch at a corner
    # (the outline pinches there), and a column touching the square only at
    # a corner (dropped, as the smaller part).
    square = {(i, j) for i in range(5) for j in range(5)} - {(1, 1), (2, 2)}
    cells = np.array(sorted(square | {(5, 5)}))
    columns = np.column_stack([np.full(len(cells), 7), cells])
    (outline,) = column_outlines(columns, np.array([7]), np.zeros(2), 1.0)
    assert outline.is_valid and outline.area == 23.0
    assert shapely.equals(outline, union_of_squares(cells[:-1], np.zeros(2), 1.0))


def test_a_straight_side_is_one_segment_and_a_block_without_columns_is_empty():
    cells = np.array([(i, j) for i in range(10) for j in range(3)])
    columns = np.column_stack([np.full(len(cells), 1), cells])
    one, none = column_outlines(columns, np.array([1, 2]), np.array([10.0, 20.0]), 2.0)
    assert shapely.get_num_coordinates(one) == 5 and one.area == 120.0
    assert none.is_empty


def test_no_columns_give_empty_polygons():
    # Every block dropped by the thresholds: no column, and no footprint (the
    # layer gets none); blocks without columns get empty polygons.
    none = np.zeros((0, 3), np.int64)
    assert len(column_outlines(none, np.zeros(0, np.int64), np.zeros(2), 1.0)) == 0
    assert all(outline.is_empty for outline in column_outlines(none, np.array([4, 9]), np.zeros(2), 1.0))
