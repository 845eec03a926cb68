"""Self-intersection control of moved surfaces (paper §6: "the quality of the
mesh must be strictly controlled during the projection procedure").

Face quality and normal checks see one face at a time; a node pushed along
its normal can still cross a face of a thin neighbouring part, and a volume
mesher then refuses the model ("a segment and a facet intersect").
:func:`undo_crossings` finds the triangles that touch a moved node and cross
a triangle they do not share a node with, and undoes the moves of their
nodes until none is left.

Broad phase: two faces can only meet if their centres are closer than the
sum of their reaches (the largest distance from a face's centre to its
corners); KD-trees over the centres, slab by slab along x or y, find those pairs,
the few large faces in classes of their own so that they do not widen the
search of all the others. The faces searched are quads (half as many as
triangles, and a quad's ball, which holds both its triangles, is smaller
than a triangle's own); only the quads met are split. Then the triangles
must share no node, and their bounding boxes must overlap. Narrow phase: an edge of one triangle crossing the other
(Moller-Trumbore on segments), both ways; coplanar touching is not reported.

With numba (:mod:`core.jit`), both phases run compiled in one pass over the
seeds (:mod:`core.crossing_kernel`), with the same crossings; the numpy code
here runs without it and stays the reference the tests compare it with.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from . import jit
from .errors import Cancelled
from .neighbours import search_tree
from .parallel import map_blocks, row_blocks, thread_count
from .progress import counted
from .quality import best_diagonal, split_along
from .topology import touching
from .vectors import Vector, coordinates, cross, dot, length, minus

#: Quantiles of the faces' reach that split them into size classes searched apart.
_CLASS_QUANTILES = (0.9, 0.99)
#: Quad pairs tested at a time (four triangle pairs each): cache-sized temporaries.
_PAIR_BLOCK = 8192
#: Faces whose balls or boxes are made at a time (a few MB of temporaries).
_ROWS = 1 << 16
#: The share of the crossing control's time before the first round's search
#: (the faces' balls and cells: a sixth of it for the 1 km city's blocks).
_BALLS_SHARE = 0.15


def _pair_rows(nodes: np.ndarray, tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper corners of the triangles' boxes as per-axis rows (3, T):
    the pair filters gather one contiguous row at a time. Made one axis at a
    time from the nodes (no (T, 3, 3) table of corners), ``_ROWS`` triangles
    at a time on all cores (:mod:`core.parallel`).

    The rows are float32 rounded outwards (a box holds its triangle): half
    the memory (470 MB -> 230 MB on the 1 km city) and of the gathers. The
    filter then keeps a few more pairs, never fewer: pairs whose boxes miss
    each other by less than a float32 step (1e-4 m at 2 km from the origin)
    go on to the crossing test, which finds no crossing in them but at its
    own round-off (the moves undone are the same on Delft, Montpellier and
    the 500 m and 1 km cities).

    Examples
    --------
    >>> lower, upper = _pair_rows(np.array([[0.1, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    >>> lower.dtype.name, bool(lower[0, 0] <= 0.0), bool(upper[0, 0] >= 1.0)
    ('float32', True, True)
    """
    # The same boxes in one pass (core.crossing_kernel).
    found = jit.run("crossing_kernel", "triangle_boxes", nodes, tri, size=len(tri))
    if found is not None:
        return found
    lower = np.empty((3, len(tri)), dtype=np.float32)
    upper = np.empty((3, len(tri)), dtype=np.float32)
    down, up = np.float32(-np.inf), np.float32(np.inf)

    def fill(rows: slice) -> None:
        corner = tri[rows]
        for c in range(3):
            x = [nodes[corner[:, j], c] for j in range(3)]
            low = np.minimum(np.minimum(x[0], x[1]), x[2])
            high = np.maximum(np.maximum(x[0], x[1]), x[2])
            low32, high32 = low.astype(np.float32), high.astype(np.float32)
            lower[c, rows] = np.where(low32 > low, np.nextafter(low32, down), low32)
            upper[c, rows] = np.where(high32 < high, np.nextafter(high32, up), high32)

    map_blocks(fill, row_blocks(len(tri), _ROWS))
    return lower, upper


def _crossing_of(qa: np.ndarray, qb: np.ndarray, tri: np.ndarray, nodes: np.ndarray,
                 rows: tuple[np.ndarray, np.ndarray], in_focus: np.ndarray) -> np.ndarray:
    """The crossing triangle pairs among the four of each quad pair
    ``(qa, qb)``, with at least one triangle in focus, that one first.

    Triangle ``2 q + k`` is triangle ``k`` of quad ``q``: ``tri`` (2M, 3)
    are node indices into ``nodes`` (N, 3), ``rows`` from
    :func:`_pair_rows`. Corners are gathered only for the pairs left after
    the cheap filters.
    """
    # Triangles sharing a node touch by construction, and the quality
    # control already covers them. Tested first, on one row gather of each
    # quad's two triangles: most close pairs are neighbours (on the 1 km
    # city 83 % of the triangle pairs whose boxes overlap share a node), and
    # the box filter then gathers for the others only.
    halves = tri.reshape(-1, 6)
    ta, tb = halves.take(qa, axis=0), halves.take(qb, axis=0)
    unshared = np.empty((len(qa), 4), dtype=bool)
    for pair, (ka, kb) in enumerate(((0, 0), (0, 1), (1, 0), (1, 1))):
        shared = ta[:, 3 * ka] == tb[:, 3 * kb]
        for i in range(3):
            for j in range(3):
                if i or j:
                    shared |= ta[:, 3 * ka + i] == tb[:, 3 * kb + j]
        unshared[:, pair] = ~shared
    del ta, tb
    pair, which = np.nonzero(unshared)  # row-major, as the mask's own indexing
    a = 2 * qa[pair] + (which >> 1)
    b = 2 * qb[pair] + (which & 1)
    lower, upper = rows
    keep = in_focus[a] | in_focus[b]
    # Bounding boxes must overlap.
    for c in range(3):
        keep &= (lower[c][a] <= upper[c][b]) & (lower[c][b] <= upper[c][a])
    a, b = a[keep], b[keep]
    pa = [coordinates(nodes, tri[a, k]) for k in range(3)]
    pb = [coordinates(nodes, tri[b, k]) for k in range(3)]
    crossing = _edges_cross(pa, pb) | _edges_cross(pb, pa)
    a, b = a[crossing], b[crossing]
    swap = ~in_focus[a]
    return np.column_stack([np.where(swap, b, a), np.where(swap, a, b)])


def _balls(nodes: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre and reach of every face (triangle or quad): the face lies in the
    ball of that radius around its centre.

    The centre is the mean of the corners, the reach the largest distance
    from it to a corner. Made one corner at a time: a (F, corners, 3) table
    of the corners is hundreds of MB on a city. The corners are summed in
    their order, as ``corner.mean(axis=1)`` does. Rows are independent:
    ``_ROWS`` at a time, on all cores (:mod:`core.parallel`).

    Examples
    --------
    >>> nodes = np.array([[0.0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0]])
    >>> centre, reach = _balls(nodes, np.array([[0, 1, 2, 3]]))
    >>> centre.tolist(), reach.round(6).tolist()
    ([[1.0, 1.0, 0.0]], [1.414214])
    """
    # The same balls in one pass (core.crossing_kernel).
    found = jit.run("crossing_kernel", "face_balls", nodes, faces, size=len(faces))
    if found is not None:
        return found
    centre = np.empty((len(faces), 3))
    reach = np.empty(len(faces))

    def fill(rows: slice) -> None:
        # Each corner gathered once, for the centre and the reach (take: row
        # gathers faster than indexing, core.vectors).
        corners = [nodes.take(column, axis=0) for column in faces[rows].T]
        total = corners[0].copy()
        for corner in corners[1:]:
            total += corner
        centre[rows] = middle = total / len(corners)
        squared = np.zeros(len(total))
        for corner in corners:
            d = corner - middle
            squared = np.maximum(squared, d[:, 0] ** 2 + d[:, 1] ** 2 + d[:, 2] ** 2)
        reach[rows] = np.sqrt(squared)

    # Blocks of rows on all cores: a block's gathers and temporaries stay in
    # the cache (one pass over 5 M quads took 1.3 s, the blocks 0.3 s).
    map_blocks(fill, row_blocks(len(faces), _ROWS))
    return centre, reach


class _Cells:
    """The faces' centres in a lattice of cubic cells of side ``radius``,
    for :meth:`near`: the faces whose centre may be within ``radius`` of a
    seed's.

    :func:`undo_crossings` keeps one across its rounds, and only the faces
    whose centre moved (their nodes put back) are placed again. A later
    round's radius is twice the largest reach then, and where it is no
    larger than the lattice's side the faces near a seed in the lattice are
    a superset of those in a lattice of that radius, which finds the same
    crossings (a pair is tested by its own balls and triangles, not by
    where its cells lie). Placing all 4.8 M faces of the 1 km city again for
    the 44 seeds of its second round took 0.115 s of the round's 0.139 s.
    """

    def __init__(self, centre: np.ndarray, radius: float):
        self.radius = max(float(radius), 1e-300)
        # One column at a time: numpy's reductions along axis 0 of an (M, 3)
        # table stride through it (0.25 s on 4.8 M centres, 0.03 s so).
        self.lowest = [centre[:, c].min() for c in range(3)]
        # The largest cell is that of the largest centre (the rounding is monotone);
        # +1 and +2: room for the -1 and +1 neighbours.
        self.dims = np.array([int(np.floor((centre[:, c].max() - self.lowest[c]) / self.radius)) + 3
                              for c in range(3)])
        self.key = np.empty(len(centre), dtype=np.int64)

        def fill(rows: slice) -> None:
            # Blocks of rows on all cores, their temporaries in the cache.
            self.key[rows] = self._keys(self._cells(centre[rows]))

        map_blocks(fill, row_blocks(len(centre), _ROWS))

    def _cells(self, centre: np.ndarray) -> list[np.ndarray]:
        """The cells of ``centre`` along each axis, from 1 (as floats)."""
        return [np.floor((centre[:, c] - self.lowest[c]) / self.radius) + 1 for c in range(3)]

    def _keys(self, cells: list[np.ndarray]) -> np.ndarray:
        i, j, k = (x.astype(np.int64) for x in cells)
        return i + self.dims[0] * (j + self.dims[1] * k)

    def moved(self, rows: np.ndarray, centre: np.ndarray) -> bool:
        """Place the faces ``rows`` again, at their new ``centre`` (one per
        row); False (nothing changed) where one falls outside the lattice."""
        cells = self._cells(centre)
        if not all(np.all((x >= 1) & (x <= d - 2)) for x, d in zip(cells, self.dims)):
            return False
        self.key[rows] = self._keys(cells)
        return True

    def near(self, seeds: np.ndarray) -> np.ndarray:
        """Sorted indices of the faces whose centre is in a cell next to (or
        in) a seed's cell: every centre within the side of a seed's (so are
        the seeds), a cheap filter that keeps the search small when the
        seeds are few."""
        key, dims = self.key, self.dims
        if np.prod(dims.astype(np.float64)) <= 4 * len(key):
            # A table of the cells (no larger than a few arrays of the faces),
            # the seeds' ones dilated by one: a lookup per face instead of a sort
            # of all the keys (np.isin).
            wanted = np.zeros(int(np.prod(dims)), dtype=bool)
            wanted[key[seeds]] = True
            wanted = _dilated(wanted.reshape(dims[::-1])).ravel()
            return np.flatnonzero(wanted[key])
        steps = np.array([dx + dims[0] * (dy + dims[1] * dz)
                          for dz in (-1, 0, 1) for dy in (-1, 0, 1) for dx in (-1, 0, 1)])
        seed_cells = np.unique(key[seeds])
        wanted = np.unique((seed_cells[:, None] + steps[None, :]).ravel())
        return np.flatnonzero(np.isin(key, wanted))


def _dilated(mask: np.ndarray) -> np.ndarray:
    """``mask`` dilated by its 3 x 3 x 3 box (outside it, False): as
    ``ndimage.binary_dilation`` with that structure, one axis at a time,
    by shifted ORs (0.19 -> 0.013 s on the 14 M cells of the 1 km city).

    Examples
    --------
    >>> mask = np.zeros((3, 4, 4), bool); mask[0, 0, 0] = True
    >>> int(_dilated(mask)[:2, :3, :3].sum()), int(_dilated(mask).sum())
    (8, 8)
    """
    mask = mask.copy()
    for axis in range(mask.ndim):
        lower = [slice(None)] * mask.ndim
        upper = [slice(None)] * mask.ndim
        lower[axis], upper[axis] = slice(None, -1), slice(1, None)
        grown = mask.copy()
        grown[tuple(upper)] |= mask[tuple(lower)]
        grown[tuple(lower)] |= mask[tuple(upper)]
        mask = grown
    return mask


def _close_pairs(centre: np.ndarray, reach: np.ndarray, faces: np.ndarray, seeds: np.ndarray,
                 chunk: int, is_cancelled: Callable[[], bool] | None):
    """Yield arrays ``(a, b)``: every pair of a seed and another face whose
    centres are closer than their reaches added up (and more).

    The faces searched are the rows ``faces`` of ``centre`` and ``reach``
    (no copy of their centres: 116 MB on the 1 km city); ``seeds``, ``a`` and
    ``b`` are positions in ``faces``. Each pair comes once, with the seed on
    either side. One search radius for all would be twice the largest reach,
    and the few stretched faces would widen it for every one: faces are put
    in size classes, and each pair of classes is searched with its own radius.

    Every face of a class is searched, seed or not, and the pairs without a
    seed are dropped: the faces are those near a seed (:meth:`_Cells.near`),
    and where the seeds are most of them (the first round), one search of
    all beats seeds against seeds and seeds against the others (1.55 s
    against 2.3 s on the 1 km city's 2.4 M faces, 1.6 M of them seeds). It
    finds no fewer pairs, and a few more with a wider radius (0.2 %).
    """
    is_seed = np.zeros(len(faces), dtype=bool)
    is_seed[seeds] = True
    reach = reach[faces]
    bounds = np.quantile(reach, _CLASS_QUANTILES)
    size_class = np.searchsorted(bounds, reach)
    members = [np.flatnonzero(size_class == k) for k in range(len(bounds) + 1)]
    del size_class

    for k, group in enumerate(members):
        if len(group) == 0:
            continue
        # Slightly wider than needed: round-off must not lose a touching pair.
        yield from _pairs_within(centre, faces, group, 2 * reach[group].max() * (1 + 1e-9), chunk,
                                 is_cancelled, is_seed)
        # Then with the faces of the larger classes, a few (the largest of
        # them) in a tree, searched a chunk of this class at a time.
        for larger in members[k + 1:]:
            if len(larger):
                radius = (reach[group].max() + reach[larger].max()) * (1 + 1e-9)
                yield from _pairs_between(centre, faces, group, larger, radius, chunk, is_cancelled, is_seed)


def _pairs_within(centre: np.ndarray, faces: np.ndarray, members: np.ndarray, radius: float,
                  chunk: int, is_cancelled: Callable[[], bool] | None,
                  marked: np.ndarray | None = None):
    """Yield arrays ``(a, b)``: every pair of ``members`` (positions in
    ``faces``, rows of ``centre``) whose centres are at most ``radius``
    apart, once; only those with a ``marked`` one (a mask over ``faces``)
    if given.

    The members are sorted along x or y, whichever they spread the more
    along, and cut into slabs of ``chunk``; a slab's tree also holds the
    band of members that follow it within ``radius`` along that axis, and
    keeps the pairs with a member of the slab itself. A pair is so found in
    the slab of the one that comes first, and only there: each pair once,
    where a search of every chunk against a tree of all the members finds
    each twice (1.2 s against 3.1 s for the 4.4 M faces of the largest size
    class of the 1 km city, on 2 cores). Where the bands would hold more
    than a chunk (members crowded within a few radii along both axes), the
    slabs' work would grow with the square of their number: those members
    are searched chunk against a tree of all, each pair kept once.

    Examples
    --------
    >>> centre = np.array([[0.0, 0, 0], [1, 0, 0], [2.5, 0, 0], [0, 0.5, 0]])
    >>> pairs = _pairs_within(centre, np.arange(4), np.arange(4), 1.0, 2, None)
    >>> sorted(tuple(sorted(p)) for a, b in pairs for p in zip(a.tolist(), b.tolist()))
    [(0, 1), (0, 3)]
    """
    along = [centre[faces[members], c] for c in range(2)]
    spread = [float(np.ptp(v)) if len(v) else 0.0 for v in along]
    axis = int(np.argmax(spread))
    if len(members) * radius > chunk * max(spread[axis], radius):
        yield from _pairs_between(centre, faces, members, None, radius, chunk, is_cancelled, marked)
        return
    order = np.argsort(along[axis], kind="stable")
    x = along[axis][order]
    del along
    def search(start: int) -> tuple[np.ndarray, np.ndarray]:
        if is_cancelled is not None and is_cancelled():
            raise Cancelled()
        end = min(start + chunk, len(members))
        band_end = int(np.searchsorted(x, x[end - 1] + radius, side="right"))
        slab = members[order[start:band_end]]
        pairs = search_tree(centre.take(faces[slab], axis=0)).query_pairs(radius, output_type="ndarray")
        pairs = pairs[pairs[:, 0] < end - start]  # query_pairs gives i < j: i is in the slab
        return _with_marked(slab[pairs[:, 0]], slab[pairs[:, 1]], marked)

    yield from _on_threads(search, list(range(0, len(members), chunk)))


def _pairs_between(centre: np.ndarray, faces: np.ndarray, members: np.ndarray, others: np.ndarray | None,
                   radius: float, chunk: int, is_cancelled: Callable[[], bool] | None,
                   marked: np.ndarray | None):
    """Yield arrays ``(a, b)``: every pair of one of ``members`` and one of
    ``others`` (positions in ``faces``, rows of ``centre``) whose centres are
    at most ``radius`` apart; only those with a ``marked`` one if given.

    A chunk of ``members`` at a time is searched against a tree of
    ``others``. Without ``others``, the members are searched against
    themselves: each pair is found from both sides and kept once.
    """
    within = others is None
    others = members if within else others
    tree = search_tree(centre.take(faces[others], axis=0))

    def search(part: slice) -> tuple[np.ndarray, np.ndarray]:
        if is_cancelled is not None and is_cancelled():
            raise Cancelled()
        part_tree = search_tree(centre.take(faces[members[part]], axis=0))
        pairs = part_tree.sparse_distance_matrix(tree, radius, output_type="ndarray")
        i, j = pairs["i"] + part.start, pairs["j"]
        if within:
            i, j = i[i < j], j[i < j]
        return _with_marked(members[i], others[j], marked)

    yield from _on_threads(search, row_blocks(len(members), chunk))


def _on_threads(search: Callable, parts: list):
    """Yield ``search(part)`` for every part, in order. The KD-tree searches
    release the GIL: a part per thread at a time (memory: one part's pairs
    per thread)."""
    for batch in row_blocks(len(parts), thread_count()):
        yield from map_blocks(search, parts[batch])


def _with_marked(a: np.ndarray, b: np.ndarray, marked: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """The pairs ``(a, b)`` with a ``marked`` member (all without a mask)."""
    if marked is None:
        return a, b
    keep = marked[a] | marked[b]
    return a[keep], b[keep]


def _edges_cross(edges_of: list[Vector], faces: list[Vector]) -> np.ndarray:
    """Whether an edge of each triangle in ``edges_of`` crosses the paired
    triangle (Moller-Trumbore).

    Both are the triangles' three corners, each a :mod:`core.vectors`
    vector (one array per coordinate, with numpy's arithmetic): the numbers
    of (P, 3) tables, two to three times faster.
    """
    v0, v1, v2 = faces
    e1, e2 = minus(v1, v0), minus(v2, v0)
    scale = 1e-12 * np.maximum(length(e1) * length(e2), 1e-300)
    hit = np.zeros(len(v0[0]), dtype=bool)
    eps = 1e-9
    for i, j in ((0, 1), (1, 2), (2, 0)):
        origin = edges_of[i]
        direction = minus(edges_of[j], origin)
        h = cross(direction, e2)
        det = dot(e1, h)
        ok = np.abs(det) > scale * np.maximum(length(direction), 1e-300)
        inv = np.divide(1.0, det, out=np.zeros_like(det), where=ok)
        s = minus(origin, v0)
        u = inv * dot(s, h)
        q = cross(s, e1)
        v = inv * dot(direction, q)
        t = inv * dot(e2, q)
        hit |= ok & (u > eps) & (v > eps) & (u + v < 1 - eps) & (t > eps) & (t < 1 - eps)
    return hit


def undo_crossings(old: np.ndarray, new: np.ndarray, moved: np.ndarray, quads: np.ndarray,
                   max_rounds: int = 20, chunk: int = 20_000,
                   is_cancelled: Callable[[], bool] | None = None,
                   overwrite_new: bool = False,
                   progress: Callable[[float, str], None] | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """Undo moves until no moved triangle crosses another.

    Each quad is split along its best diagonal (:func:`core.quality.best_diagonal`)
    at the current positions. A round finds the triangles touching a moved
    node that cross another (after the first round, only those whose centre
    is near what the last round undid), and puts back all the moved nodes of
    both.

    Parameters
    ----------
    old, new : ndarray (N, 3)
        Positions before and after the moves.
    moved : ndarray of bool (N,)
        Nodes whose move was kept so far.
    quads : ndarray (M, 4)
        Every face of the model.
    chunk : int
        Quads searched at a time (bounds the memory of the pair lists).
    overwrite_new : bool
        The moves are undone in ``new``, which is returned, instead of in a copy
        (as :func:`core.quality.accept_moves`).
    progress : callable, optional
        ``progress(fraction, message)`` as the first round's compiled search
        goes over the seeds (most of the time: 1.6 of 2.5 s on the 1 km
        city; the later rounds look at a few faces).

    Returns
    -------
    positions, moved, undone
        Updated positions and mask, and how many moves were undone.
    """
    positions = new if overwrite_new else new.copy()
    moved = moved.copy()
    undone = 0
    near = None  # after a round, only the neighbourhood of what was undone can still cross
    centre, reach = _balls(positions, quads)
    if progress is not None:
        progress(_BALLS_SHARE, "face crossings")
    # The best diagonal of the quads met so far (a flag per quad, not their
    # triangles: 233 MB on the 1 km city); a quad whose nodes are put back is
    # split again when it is next met.
    diagonal = np.zeros(len(quads), dtype=bool)
    split = np.zeros(len(quads), dtype=bool)
    # First round: the quads around a moved node. Later: the quads changed
    # since the first round. A pair that crossed then lost every move of its
    # nodes, so a pair found later has a triangle changed since; the others
    # were tested then and need no new test.
    seeds = np.flatnonzero(touching(moved, quads))
    changed = np.zeros(len(quads), dtype=bool)
    cells = None  # the faces in cells of twice the largest reach, kept from round to round
    for _ in range(max_rounds):
        if len(seeds) == 0:
            break
        radius = 2 * reach.max()
        if cells is None or radius > cells.radius:
            cells = _Cells(centre, radius)
        # The first round's seeds, as the compiled search's threads finish them.
        searched = None
        if near is None and progress is not None:
            searched = counted(lambda share: progress(_BALLS_SHARE + (1 - _BALLS_SHARE) * share, "face crossings"),
                               len(seeds))
        pairs = _crossing_quads(positions, quads, diagonal, split, centre, reach, seeds, moved, near,
                                cells, chunk, is_cancelled, searched)
        if len(pairs) == 0:
            break
        culprits = np.unique(pairs)
        culprits = culprits[moved[culprits]]
        if len(culprits) == 0:
            break  # crossings not caused by these moves
        moved_to = positions[culprits]  # new[culprits], which may be positions itself
        positions[culprits] = old[culprits]
        moved[culprits] = False
        undone += len(culprits)
        span = 4 * np.linalg.norm(np.ptp(positions[quads[0]], axis=0))  # a few faces around
        near = (np.minimum(old[culprits], moved_to).min(axis=0) - span,
                np.maximum(old[culprits], moved_to).max(axis=0) + span)
        reverted = np.zeros(len(old), dtype=bool)
        reverted[culprits] = True
        touched = np.flatnonzero(touching(reverted, quads))
        centre[touched], reach[touched] = _balls(positions, quads.take(touched, axis=0))
        if not cells.moved(touched, centre[touched]):
            cells = None
        split[touched] = False
        changed[touched] = True
        seeds = np.flatnonzero(changed)
    return positions, moved, undone


def _crossing_quads(positions: np.ndarray, quads: np.ndarray, diagonal: np.ndarray, split: np.ndarray,
                    centre: np.ndarray, reach: np.ndarray, seeds: np.ndarray, moved: np.ndarray,
                    near: tuple[np.ndarray, np.ndarray] | None, cells: _Cells, chunk: int,
                    is_cancelled: Callable[[], bool] | None,
                    searched: Callable[[int], None] | None = None) -> np.ndarray:
    """One round of :func:`undo_crossings`: the node triples of the crossing
    triangle pairs (P, 2, 3) with a triangle of a ``seeds`` quad and one in focus.

    ``diagonal`` and ``split`` (the quads whose ``diagonal`` is that of
    their current best split) are completed in place for the quads met.
    """
    if len(seeds) == 0:
        return np.zeros((0, 2, 3), dtype=quads.dtype)
    # A triangle lies in its quad's ball: quads whose balls do not meet hold
    # no pair of touching triangles (cells at least twice the largest reach).
    sub = cells.near(seeds)
    todo = sub[~split[sub]]
    if len(todo):
        diagonal[todo] = best_diagonal(positions, quads.take(todo, axis=0))
        split[todo] = True
    # Triangle 2 i + k here is triangle k of quad sub[i]; 32-bit node numbers
    # where they fit halve the table and its gathers.
    index = np.int32 if len(positions) < 2**31 else quads.dtype
    tri = split_along(quads.take(sub, axis=0), diagonal[sub], index)
    in_focus = touching(moved, tri)
    if near is not None:
        # The centre, as the mean of the three corners (summed in their order).
        mid = (positions.take(tri[:, 0], axis=0) + positions.take(tri[:, 1], axis=0)
               + positions.take(tri[:, 2], axis=0)) / 3
        in_focus &= np.all((mid >= near[0]) & (mid <= near[1]), axis=1)
    rows = _pair_rows(positions, tri)
    if jit.kernels("crossing_kernel", len(sub)) is not None:
        # One compiled pass over the seeds, the same crossings (core.crossing_kernel).
        pairs = jit.run("crossing_kernel", "crossing_triangles", centre.take(sub, axis=0), reach.take(sub),
                        np.searchsorted(sub, seeds), tri, positions, rows, in_focus, is_cancelled, searched)
        if pairs is not None:
            return tri.take(pairs, axis=0)
    found = [np.zeros((0, 2), dtype=np.int64)]
    for qa, qb in _close_pairs(centre, reach, sub, np.searchsorted(sub, seeds), chunk, is_cancelled):

        def test(block: slice, qa: np.ndarray = qa, qb: np.ndarray = qb) -> np.ndarray:
            # The four triangle pairs of each quad pair (two quads never share both triangles).
            return _crossing_of(qa[block], qb[block], tri, positions, rows, in_focus)

        # The pairs a few thousand at a time, on all cores: the filters'
        # temporaries stay in the cache (each pair is tested on its own, so
        # the pairs found are the same, in the same order).
        found.extend(map_blocks(test, row_blocks(len(qa), _PAIR_BLOCK)))
    return tri.take(np.concatenate(found), axis=0)
