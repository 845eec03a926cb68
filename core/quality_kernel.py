"""Compiled quad quality (numba, :mod:`core.jit`).

Every quality-controlled move (the smoothing's passes, the projection, the
crossing control's splits, the measures) asks, for each quad it touches,
which diagonal splits it better, the quality of that split and the quad's
normal (:func:`core.quality._split_quality_of`). numpy computes it as some
fifty elementwise passes over blocks of quads: 2.6 s of the 1 km synthetic
city's method, in calls of a few thousand to millions of quads. Here each
quad is one pass over its four corners, with the arithmetic of
:func:`core.quality._split_quality_of` operation for operation (the
:mod:`core.vectors` orders: ``dot`` adds the x and z products first,
``length`` the x and y squares), so the results are the same to the last
bit; the tests compare both.
"""
from __future__ import annotations

import numpy as np

from .neighbours_kernel import compiled, inlined, length, maximum, minimum
from .parallel import balanced_blocks, map_blocks

#: The normalisation of :func:`core.quality.triangle_quality` (an equilateral triangle scores 1).
_SCALE = float(4 * np.sqrt(3))


def split_quality(nodes: np.ndarray, quads: np.ndarray,
                  normals: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Which split of each quad is better, its quality, and the quad's normal:
    :func:`core.quality._split_quality`.

    Parameters
    ----------
    nodes : ndarray (N, 3)
    quads : ndarray of int (M, 4)
    normals : bool
        Also the normals (else None).

    Returns
    -------
    use_second : ndarray of bool (M,)
    quality : ndarray (M,)
    normal : ndarray (M, 3) or None

    Examples
    --------
    A kite is split along its short diagonal (1-3):

    >>> nodes = np.array([[0, 0, 0], [1, -0.2, 0], [2, 0, 0], [1, 0.2, 0]], float)
    >>> use_second, quality, normal = split_quality(nodes, np.array([[0, 1, 2, 3]]))
    >>> use_second.tolist(), normal.tolist()
    ([True], [[0.0, 0.0, 0.4]])
    """
    nodes = np.ascontiguousarray(nodes, dtype=np.float64)
    quads = np.ascontiguousarray(quads)
    m = len(quads)
    use_second = np.empty(m, dtype=np.bool_)
    quality = np.empty(m)
    normal = np.empty((m if normals else 0, 3))

    def fill(rows: slice) -> None:
        _fill(nodes, quads, rows.start, rows.stop, use_second, quality, normal, normals)

    map_blocks(fill, balanced_blocks(m))
    return use_second, quality, normal if normals else None


def split_quality_into(nodes: np.ndarray, quads: np.ndarray, rows: np.ndarray, quality: np.ndarray,
                       normal: np.ndarray) -> int:
    """The quality and normal of the quads ``rows`` (:func:`split_quality`)
    written into the same rows of ``quality`` (M,) and ``normal`` (M, 3):
    :func:`core.quality._split_quality_into`, without a table of their
    quads gathered first nor of their results scattered after. Returns how
    many quads were computed.

    Examples
    --------
    >>> nodes = np.array([[0, 0, 0], [1, -0.2, 0], [2, 0, 0], [1, 0.2, 0]], float)
    >>> quality, normal = np.zeros(2), np.zeros((2, 3))
    >>> split_quality_into(nodes, np.array([[0, 0, 0, 0], [0, 1, 2, 3]]), np.array([1]), quality, normal)
    1
    >>> normal.tolist()
    [[0.0, 0.0, 0.0], [0.0, 0.0, 0.4]]
    """
    nodes = np.ascontiguousarray(nodes, dtype=np.float64)
    quads = np.ascontiguousarray(quads)
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    map_blocks(lambda part: _fill_rows(nodes, quads, rows, part.start, part.stop, quality, normal),
               balanced_blocks(len(rows)))
    return len(rows)


def warm_up() -> int:
    """Compile for the quad tables the pipeline passes (int64 and int32 node numbers)."""
    nodes = np.array([[0, 0, 0], [1, -0.2, 0], [2, 0, 0], [1, 0.2, 0]], float)
    for dtype in (np.int64, np.int32):
        for normals in (True, False):
            use_second, _, _ = split_quality(nodes, np.array([[0, 1, 2, 3]], dtype=dtype), normals)
            assert use_second.tolist() == [True], use_second
        quality, normal = np.zeros(1), np.zeros((1, 3))
        split_quality_into(nodes, np.array([[0, 1, 2, 3]], dtype=dtype), np.zeros(1, np.int64), quality, normal)
        assert normal.tolist() == [[0.0, 0.0, 0.4]], normal
    return 1


@compiled
def _triangle(ab, bc, ca, ux, uy, uz, vx, vy, vz, nx, ny, nz):
    """The inner ``quality`` of :func:`core.quality._split_quality_of`: the
    triangle with sides ab, bc, ca and cross(b - a, c - a) = cross(u, v),
    0 when it faces away from the quad's normal n."""
    tx, ty, tz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    area = 0.5 * length(tx, ty, tz)
    longest = maximum(maximum(ab, bc), ca)
    denominator = (ab + bc + ca) * longest
    q = _SCALE * area / denominator if denominator > 0 else 0.0
    facing = ((tx * nx + tz * nz) + ty * ny) > 0
    return q if facing else 0.0


@compiled
def _fill(nodes, quads, start, stop, use_second, quality, normal, normals):
    """Rows ``start:stop`` of :func:`split_quality`."""
    for m in range(start, stop):
        better, q, nx, ny, nz = _split_of(nodes, quads, m)
        use_second[m] = better
        quality[m] = q
        if normals:
            normal[m, 0], normal[m, 1], normal[m, 2] = nx, ny, nz


@compiled
def _fill_rows(nodes, quads, rows, start, stop, quality, normal):
    """The quads ``rows[start:stop]`` of :func:`split_quality_into`."""
    for t in range(start, stop):
        m = rows[t]
        _, q, nx, ny, nz = _split_of(nodes, quads, m)
        quality[m] = q
        normal[m, 0], normal[m, 1], normal[m, 2] = nx, ny, nz


@inlined
def _split_of(nodes, quads, m):
    """Quad ``m``'s better split (whether the second), its quality and its normal."""
    a, b, c, d = quads[m, 0], quads[m, 1], quads[m, 2], quads[m, 3]
    x0, y0, z0 = nodes[a, 0], nodes[a, 1], nodes[a, 2]
    x1, y1, z1 = nodes[b, 0], nodes[b, 1], nodes[b, 2]
    x2, y2, z2 = nodes[c, 0], nodes[c, 1], nodes[c, 2]
    x3, y3, z3 = nodes[d, 0], nodes[d, 1], nodes[d, 2]
    # The sides and diagonals, each once (d_ij = p_j - p_i).
    d01x, d01y, d01z = x1 - x0, y1 - y0, z1 - z0
    d12x, d12y, d12z = x2 - x1, y2 - y1, z2 - z1
    d23x, d23y, d23z = x3 - x2, y3 - y2, z3 - z2
    d30x, d30y, d30z = x0 - x3, y0 - y3, z0 - z3
    d02x, d02y, d02z = x2 - x0, y2 - y0, z2 - z0
    d13x, d13y, d13z = x3 - x1, y3 - y1, z3 - z1
    l01, l12, l23 = length(d01x, d01y, d01z), length(d12x, d12y, d12z), length(d23x, d23y, d23z)
    l30, l02, l13 = length(d30x, d30y, d30z), length(d02x, d02y, d02z), length(d13x, d13y, d13z)
    # The quad's normal: half the cross product of its diagonals.
    nx = 0.5 * (d02y * d13z - d02z * d13y)
    ny = 0.5 * (d02z * d13x - d02x * d13z)
    nz = 0.5 * (d02x * d13y - d02y * d13x)
    first = minimum(_triangle(l01, l12, l02, d01x, d01y, d01z, d02x, d02y, d02z, nx, ny, nz),
                    _triangle(l02, l23, l30, d02x, d02y, d02z, -d30x, -d30y, -d30z, nx, ny, nz))
    second = minimum(_triangle(l12, l23, l13, d12x, d12y, d12z, d13x, d13y, d13z, nx, ny, nz),
                     _triangle(l13, l30, l01, d13x, d13y, d13z, -d01x, -d01y, -d01z, nx, ny, nz))
    better = second > first
    return better, (second if better else first), nx, ny, nz
