"""Self-intersection control of projected surfaces (core.intersect)."""
import numpy as np

from core.intersect import crossing_triangles, undo_crossings


def two_plates(gap):
    """Two parallel unit squares (two quads), ``gap`` apart in z."""
    nodes = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                      [0, 0, gap], [1, 0, gap], [1, 1, gap], [0, 1, gap]], float)
    quads = np.array([[0, 1, 2, 3], [4, 5, 6, 7]])
    return nodes, quads


def test_a_node_pushed_through_the_plate_above_is_put_back():
    old, quads = two_plates(0.5)
    new = old.copy()
    new[0] = [0.3, 0.3, 1.0]          # through the upper plate
    moved = np.zeros(8, bool)
    moved[0] = True
    positions, kept, undone = undo_crossings(old, new, moved, quads)
    assert undone == 1 and not kept[0]
    assert np.array_equal(positions, old)


def test_moves_that_cross_nothing_are_kept():
    old, quads = two_plates(0.5)
    new = old.copy()
    new[0] = [0.0, 0.0, 0.2]          # rises, stays below the upper plate
    moved = np.zeros(8, bool)
    moved[0] = True
    positions, kept, undone = undo_crossings(old, new, moved, quads)
    assert undone == 0 and kept[0]
    assert np.array_equal(positions, new)


def test_adjacent_triangles_are_not_reported():
    nodes = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
    triangles = np.array([[0, 1, 2], [1, 3, 2]])
    assert len(crossing_triangles(nodes, triangles, np.array([0, 1]))) == 0
