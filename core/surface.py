"""Conforming quad surfaces with the two regions every quad separates (§3.3).

One array of nodes (the lattice corners that any surface uses), one array of
quads, and for each quad the pair of regions on its two sides. A region is a
building block (id ``1..n``), the ground, the air, or the outside of the
domain. Every output is a selection of quads from this one model — a block's
closed surface, the ground's, the air's, an interface between two regions —
so the meshes of neighbouring regions share their nodes by construction.

Quads are oriented so that their normal points from ``regions[:, 0]`` into
``regions[:, 1]``; :meth:`SurfaceModel.closed_surface` flips the ones that
must point out of the region asked for. Paper: "the normal vector to the
face must point out of the building cell which contains the face".
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from . import jit
from .classify import AIR, GROUND
from .grid import VoxelGrid
from .parallel import map_blocks, row_blocks
from .topology import dense_unique

#: Voxels per slab of :func:`region_volume` (masks of a few MB).
_SLAB_VOXELS = 1 << 22
#: Region ids of the non-building regions; blocks are 1..n.
GROUND_REGION, AIR_REGION, OUTSIDE_REGION = -1, -2, -3
REGION_NAMES = {GROUND_REGION: "ground", AIR_REGION: "air", OUTSIDE_REGION: "outside"}

# Corner offsets (lattice steps) of a face normal to each axis, counter-clockwise
# seen from the positive side of the axis (so the normal is +axis).
_CORNERS = np.array([
    [[0, 0, 0], [0, 1, 0], [0, 1, 1], [0, 0, 1]],
    [[0, 0, 0], [0, 0, 1], [1, 0, 1], [1, 0, 0]],
    [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]],
])


def region_volume(labels: np.ndarray, blocks: np.ndarray, overwrite_blocks: bool = False) -> np.ndarray:
    """Region id of every voxel: block id, ``GROUND_REGION`` or ``AIR_REGION``.

    With ``overwrite_blocks`` (int32 ``blocks`` the caller gives up) the ids
    are written into ``blocks`` itself: a grid of 4 bytes per voxel less
    (340 MB on the 1 km city at 1 m) and no copy of it (0.3-0.5 s).

    Examples
    --------
    >>> from core.classify import BUILDING
    >>> labels = np.array([[[GROUND, BUILDING, AIR]]], np.uint8)
    >>> region_volume(labels, np.array([[[0, 7, 0]]], np.int32)).tolist()
    [[[-1, 7, -2]]]
    """
    regions = blocks if overwrite_blocks and blocks.dtype == np.int32 else blocks.astype(np.int32, copy=True)

    def fill(rows: slice) -> None:
        # Slabs of x on all cores, their masks in the cache (0.12 -> 0.05 s
        # on the 1 km city's 80 M voxels).
        np.copyto(regions[rows], GROUND_REGION, where=labels[rows] == GROUND)
        np.copyto(regions[rows], AIR_REGION, where=labels[rows] == AIR)

    plane = max(1, int(np.prod(labels.shape[1:])))
    map_blocks(fill, row_blocks(labels.shape[0], max(1, _SLAB_VOXELS // plane)))
    return regions


@dataclass
class SurfaceModel:
    """All interfaces of a voxel model as one conforming quad mesh.

    Attributes
    ----------
    nodes : ndarray of float64, shape (N, 3)
        Local node coordinates.
    quads : ndarray of int64, shape (M, 4)
        Node indices, normal from ``regions[:, 0]`` into ``regions[:, 1]``
        (shape (M, 3) once :meth:`triangulated`).
    regions : ndarray of int32, shape (M, 2)
        The regions behind and in front of each quad.
    """

    nodes: np.ndarray
    quads: np.ndarray
    regions: np.ndarray

    @classmethod
    def from_regions(cls, grid: VoxelGrid, regions: np.ndarray,
                     progress: Callable[[float], None] | None = None) -> "SurfaceModel":
        """Extract every face between two different regions.

        The domain is padded with ``OUTSIDE_REGION`` so the ground, the air and
        any block cut by the domain border get closing faces on the box.
        ``progress(share)`` is told when the faces are found (0.75 of the
        work when measured: 0.73 of 0.98 s on the 1 km synthetic city at 1 m;
        0.51-0.61 since the faces are found column by column), before their
        nodes are numbered.

        Examples
        --------
        One building voxel on one ground voxel, in a 1 x 1 x 3 domain:

        >>> g = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (1, 1, 3))
        >>> r = np.array([GROUND_REGION, 1, AIR_REGION], np.int32).reshape(1, 1, 3)
        >>> s = SurfaceModel.from_regions(g, r)
        >>> len(s.nodes), len(s.quads), len(s.closed_surface(1))
        (16, 16, 6)
        """
        nx1, ny1, nz1 = (np.asarray(regions.shape) + 1)
        flat, pairs = faces_between(regions)
        if progress is not None:
            progress(0.75)
        used, inverse = unique_nodes(flat, nx1 * ny1 * nz1)
        del flat
        return cls(nodes=grid.node_xyz(used, int(nx1), int(ny1)), quads=inverse.reshape(-1, 4).astype(np.int64),
                   regions=pairs)

    def triangulated(self, diagonal: np.ndarray | None = None) -> "SurfaceModel":
        """The same model with every quad split into its two best triangles.

        The split is chosen once per quad, on the model's own orientation, so
        the two regions of a face share the same two triangles: after the
        nodes have moved a quad is not planar, and splitting each region's
        copy separately could pick different diagonals and open a gap.
        ``diagonal`` is each quad's best (:func:`core.quality.best_diagonal`)
        when the caller has it.
        """
        from .quality import best_diagonal, split_along

        if self.quads.shape[1] == 3:
            return self
        if diagonal is None:
            diagonal = best_diagonal(self.nodes, self.quads)
        return SurfaceModel(nodes=self.nodes, quads=split_along(self.quads, diagonal),
                            regions=np.repeat(self.regions, 2, axis=0))

    def selected(self, keep: np.ndarray) -> "SurfaceModel":
        """The faces ``keep`` (a mask over the faces), in their order, on the same nodes.

        Examples
        --------
        >>> g = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (1, 1, 3))
        >>> s = SurfaceModel.from_regions(g, np.array([GROUND_REGION, 1, AIR_REGION], np.int32).reshape(1, 1, 3))
        >>> block = s.selected((s.regions == 1).any(axis=1))
        >>> len(block.quads), block.nodes is s.nodes, bool((block.regions == 1).any(axis=1).all())
        (6, True, True)
        """
        return SurfaceModel(nodes=self.nodes, quads=self.quads.compress(keep, axis=0),
                            regions=self.regions.compress(keep, axis=0))

    def region_ids(self) -> np.ndarray:
        """Every region that has a face (blocks, ground, air, outside)."""
        return dense_unique(self.regions)

    def faces_of(self, region: int) -> np.ndarray:
        """Indices of the quads that bound ``region``."""
        return np.flatnonzero((self.regions[:, 0] == region) | (self.regions[:, 1] == region))

    def closed_surface(self, region: int) -> np.ndarray:
        """Quads bounding ``region``, oriented with normals pointing out of it."""
        index = self.faces_of(region)
        quads = self.quads.take(index, axis=0)  # a copy, faster than indexing (core.vectors)
        inward = self.regions[index, 1] == region
        quads[inward] = quads.compress(inward, axis=0)[:, ::-1]
        return quads

    def closed_surfaces(self, regions: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`closed_surface` of each of ``regions``, one after the other.

        One sort of the faces' two sides instead of a scan of every face
        per region: a city has thousands of blocks and millions of faces.

        Parameters
        ----------
        regions : sequence of int
            Distinct region ids, in the order wanted.

        Returns
        -------
        quads : ndarray of int, shape (F, K)
            ``closed_surface(regions[0])``, then ``closed_surface(regions[1])``, ...
        region : ndarray of int32, shape (F,)
            The region each row bounds.

        Examples
        --------
        >>> g = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (1, 1, 3))
        >>> s = SurfaceModel.from_regions(g, np.array([GROUND_REGION, 1, AIR_REGION], np.int32).reshape(1, 1, 3))
        >>> quads, region = s.closed_surfaces([1, GROUND_REGION])
        >>> np.array_equal(quads, np.concatenate([s.closed_surface(1), s.closed_surface(GROUND_REGION)]))
        True
        """
        wanted = np.asarray(regions, dtype=np.int64)
        m = len(self.quads)
        if len(wanted) == 0 or m == 0:
            return self.quads[:0].copy(), np.zeros(0, dtype=np.int32)
        # Face f's two sides are entries 2 f and 2 f + 1: in entry order each
        # region meets its faces in face order (a face has two different
        # regions), so a stable sort on the rank alone gives, per region, the
        # faces of closed_surface in its order. Small ranks sort by radix.
        side_region = self.regions.ravel()
        rank = rank_in(side_region, wanted)
        # The same rows in two passes over the sides (core.surface_kernel).
        found = jit.run("surface_kernel", "sides_by_rank", self.quads, self.regions, rank, len(wanted), size=len(rank))
        if found is not None:
            return found
        entry = np.flatnonzero(rank >= 0)
        key = rank[entry].astype(np.int16 if len(wanted) <= np.iinfo(np.int16).max else np.int64)
        entry = entry[np.argsort(key, kind="stable")]
        quads = self.quads.take(entry >> 1, axis=0)  # faster than indexing (core.vectors)
        inward = (entry & 1).astype(bool)  # side 1: the face points into the region, flip it
        quads[inward] = quads.compress(inward, axis=0)[:, ::-1]
        return quads, side_region[entry].astype(np.int32)

    def on_block(self) -> np.ndarray:
        """Whether each face bounds a block (a region id above 0 on either side).

        Examples
        --------
        >>> g = VoxelGrid(np.zeros(3), np.zeros(3), 1.0, (1, 1, 3))
        >>> s = SurfaceModel.from_regions(g, np.array([GROUND_REGION, 1, AIR_REGION], np.int32).reshape(1, 1, 3))
        >>> int(s.on_block().sum()), len(s.quads)
        (6, 16)
        """
        return (self.regions[:, 0] > 0) | (self.regions[:, 1] > 0)

    def block_faces(self) -> tuple[np.ndarray, np.ndarray]:
        """Every face of every block, oriented out of it, and the block owning each.

        Blocks never touch each other, so each face belongs to at most one block.
        """
        a, b = self.regions[:, 0], self.regions[:, 1]
        first, second = a > 0, b > 0
        # take and compress: row gathers faster than indexing (core.vectors).
        faces = np.concatenate([self.quads.compress(first, axis=0), self.quads.compress(second, axis=0)[:, ::-1]])
        return faces, np.concatenate([a[first], b[second]])

    def interface(self, a: int, b: int) -> np.ndarray:
        """Quads between regions ``a`` and ``b``, normals from ``a`` into ``b``."""
        forward = (self.regions[:, 0] == a) & (self.regions[:, 1] == b)
        backward = (self.regions[:, 0] == b) & (self.regions[:, 1] == a)
        return np.concatenate([self.quads.compress(forward, axis=0),
                               self.quads.compress(backward, axis=0)[:, ::-1]])

    def face_count_per_block(self, n_blocks: int) -> np.ndarray:
        """Number of faces bounding each block ``1..n``."""
        ids = self.regions.ravel()
        ids = ids[ids > 0]
        return np.bincount(ids, minlength=n_blocks + 1)[1:]


def rank_in(values: np.ndarray, wanted: Sequence[int]) -> np.ndarray:
    """The index in ``wanted`` (distinct ids) of every value, -1 for values not in it.

    Examples
    --------
    >>> rank_in(np.array([[7, -1], [3, 5]]), [5, 7, -1]).tolist()
    [[1, 2], [-1, 0]]
    >>> rank_in(np.array([10**6, 4, 3]), [3, 10**6]).tolist()  # ids far apart, sorted
    [1, -1, 0]
    """
    wanted = np.asarray(wanted, dtype=np.int64)
    values = np.asarray(values)
    if len(wanted) == 0:
        return np.full(values.shape, -1, dtype=np.int64)
    low, high = int(wanted.min()), int(wanted.max())
    if high - low < max(values.size, 1024):
        # A table over the ids' range, -1 on either side of it: a lookup
        # per value, not a binary search.
        table = np.full(high - low + 3, -1, dtype=np.int64)
        table[wanted - low + 1] = np.arange(len(wanted))
        # The lookups' indices in one table, shifted and clipped in place, not
        # in three more of the values' size (155 MB each for the 19.4 M sides
        # of the 1 km city's triangles: a PLY's page faults 803 -> 747 MB).
        index = values.astype(np.int64)
        index -= low - 1
        np.clip(index, 0, high - low + 2, out=index)
        return table.take(index)
    if (wanted[1:] > wanted[:-1]).all():  # already sorted (the projection's planes): no sort
        order, ordered = np.arange(len(wanted)), wanted
    else:
        order = np.argsort(wanted)
        ordered = wanted[order]
    at = np.minimum(np.searchsorted(ordered, values), len(wanted) - 1)
    return np.where(ordered[at] == values, order[at], -1)


def unique_pairs(pairs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(pairs, axis=0, return_inverse=True)`` of (F, 2) small
    integers (region pairs, tile coordinates), by one key per row: a sort of
    F numbers instead of F rows.

    Examples
    --------
    >>> rows, inverse = unique_pairs(np.array([[1, -2], [-1, 3], [1, -2]]))
    >>> rows.tolist(), inverse.tolist()
    ([[-1, 3], [1, -2]], [1, 0, 1])
    """
    if len(pairs) == 0:
        return pairs.reshape(0, 2), np.zeros(0, dtype=np.int64)
    low = pairs.min()
    span = int(pairs.max()) - int(low) + 1
    keys, which = dense_unique((pairs[:, 0] - low).astype(np.int64) * span + (pairs[:, 1] - low),
                               return_inverse=True)
    return np.column_stack([keys // span, keys % span]) + low, which.ravel()


def faces_between(regions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every face between two voxels of different regions, the domain padded
    with ``OUTSIDE_REGION``: its corners as flat lattice node numbers (M, 4),
    ``i + (nx + 1) (j + (ny + 1) k)``, and the regions behind and in front of
    it (M, 2) int32; the faces normal to x, then y, then z, each axis's in
    the C order of the voxel behind them.

    Examples
    --------
    >>> quads, pairs = faces_between(np.ones((1, 1, 1), np.int32))
    >>> len(quads), pairs[:2].tolist()
    (6, [[-3, 1], [1, -3]])
    """
    # The same faces in two passes over the volume, no padded copy (core.surface_kernel).
    found = jit.run("surface_kernel", "faces_between", regions, OUTSIDE_REGION, _CORNERS, size=regions.size)
    if found is not None:
        return found
    padded = np.pad(regions, 1, constant_values=OUTSIDE_REGION)
    _, py, pz = padded.shape
    cells = padded.ravel()
    nx1, ny1, _ = (np.asarray(regions.shape) + 1)
    quads, pairs = [], []
    for axis in range(3):
        lower = [slice(None)] * 3
        upper = [slice(None)] * 3
        lower[axis] = slice(0, -1)
        upper[axis] = slice(1, None)
        back = padded[tuple(lower)]
        front = padded[tuple(upper)]
        # The differing pairs in C order (as np.argwhere lists them), as
        # flat indices split by divmod: argwhere's (F, 3) table and the
        # gathers through it took half of the extraction.
        where = np.flatnonzero(back != front)
        i, rest = np.divmod(where, back.shape[1] * back.shape[2])
        j, k = np.divmod(rest, back.shape[2])
        del where, rest
        # back[i, j, k] is padded[i, j, k]; front is one step along the axis.
        at = (i * py + j) * pz + k
        pairs.append(np.column_stack([cells[at], cells[at + (py * pz, pz, 1)[axis]]]))
        del at
        # Padded cell p and p + e_axis share the face whose lowest lattice
        # node is (p - 1) + e_axis in unpadded node indices.
        base = [i - 1, j - 1, k - 1]
        base[axis] += 1
        del i, j, k
        # The flat index is linear in (i, j, k): the base node's, plus each
        # corner's offset (no (F, 4, 3) table of corners: 470 MB on a city).
        first = base[0] + nx1 * (base[1] + ny1 * base[2])
        del base
        corner = _CORNERS[axis]
        quads.append(first[:, None] + (corner[:, 0] + nx1 * (corner[:, 1] + ny1 * corner[:, 2]))[None, :])
    # Freed before the node numbering's lattice-sized tables are made.
    del padded, cells, back, front
    return np.concatenate(quads), np.concatenate(pairs).astype(np.int32)


def unique_nodes(flat: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(flat, return_inverse=True)`` for node numbers below
    ``size`` (``flat`` of any shape: the caller reshapes the inverse).

    A mark per node and a running count give the same sorted nodes and
    ranks in linear time. They cost 5 bytes per node of the numbering (about
    the region volume's 4 per voxel): where it is much larger than the
    number of corners, or huge, the sort is kept.

    Examples
    --------
    >>> used, inverse = unique_nodes(np.array([[7, 2], [2, 9]]), 10)
    >>> used.tolist(), inverse.reshape(2, 2).tolist()
    ([2, 7, 9], [[1, 0], [0, 2]])
    """
    if size <= 64 * flat.size + 2**26:
        # The same, with a bit per node of the numbering (core.surface_kernel).
        found = jit.run("surface_kernel", "unique_nodes", flat, size, size=flat.size)
        if found is not None:
            return found
    if size > min(16 * flat.size, 400_000_000):
        return np.unique(flat, return_inverse=True)
    used = np.zeros(size, dtype=bool)
    used[flat] = True
    nodes = np.flatnonzero(used)
    rank = np.zeros(size, dtype=np.int64 if len(nodes) > np.iinfo(np.int32).max else np.int32)
    rank[nodes] = np.arange(len(nodes))
    return nodes, rank[flat]
