"""The result of a reconstruction, and its outputs.

:class:`Reconstruction` holds what :mod:`core.pipeline` made (grid, block
table, voxel surfaces, final mesh, per-block measures) and writes it out:
the attribute rows and WKB geometries of the Processing layers, the mesh
files (:mod:`core.export`) and the preview picture (:mod:`core.preview`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

import numpy as np

from .blocks import BlockTable
from .crs import metres_per_unit
from .grid import VoxelGrid
from .heap import reusing_freed_memory
from .measure import BlockMeasures
from .progress import Text
from .surface import SurfaceModel
from .topology import stable_order


#: The warning of a run (or a tile) that keeps no block.
NO_BLOCK = Text("No building block in the result.")


@dataclass
class Reconstruction:
    """The voxel model of a city: blocks with attributes and conforming surfaces.

    Lengths in the attribute table are in CRS units; :meth:`block_rows`
    reports them in metres.
    """

    crs: "pyproj.CRS"  # noqa: F821 - pyproj is imported lazily by the readers
    grid: VoxelGrid
    blocks: BlockTable
    surface: SurfaceModel          # the voxel model's faces (§3.3-3.4)
    mesh: SurfaceModel             # the same faces, smoothed and projected (§4)
    measures: BlockMeasures        # of ``mesh``, per block
    footprint_columns: np.ndarray  # (P, 3): block id, i, j of every column a block covers
    warnings: list[str] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    stats: dict = field(default_factory=dict)
    #: Best diagonal of every face between a block and another region of
    #: ``mesh``, in its order (:func:`core.measure.block_face_split`), as the
    #: measures found it; None where not carried (a tiled run's merge).
    block_diagonal: np.ndarray | None = field(default=None, repr=False, compare=False)
    #: For each block of :attr:`blocks`, the identifiers of the input's
    #: buildings it holds (:mod:`core.block_buildings`); None where the input
    #: names none (point clouds, mesh files).
    block_buildings: list[tuple[str, ...]] | None = field(default=None, repr=False, compare=False)
    #: :attr:`mesh_triangles`, once made.
    _triangles: SurfaceModel | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def metres_per_unit(self) -> float:
        return metres_per_unit(self.crs)

    @property
    def summary(self) -> dict:
        """Block count and total volume (m³), for scripts and the Processing outputs."""
        m = self.metres_per_unit
        return {
            "block_count": int(len(self.blocks)),
            "total_volume": float(self.blocks.volume.sum() * m**3),
            "voxel_size": float(self.grid.voxel_size * m),
            "grid_shape": [int(n) for n in self.grid.shape],
            "timings": {k: float(v) for k, v in self.timings.items()},
        }

    def block_rows(self) -> list[dict]:
        """One dict per block, plain Python numbers (GPKG drops numpy scalars).

        ``volume``, ``surface_area``, ``footprint_area`` and ``height`` are of
        the voxel model (§3); ``mesh_volume``, ``mesh_area``, ``roof_area``,
        ``facade_area``, the qualities and the distances are of the final
        smoothed, projected mesh (§4). Lengths in metres. Where the input names
        its buildings (:attr:`block_buildings`), ``building_ids`` (their
        identifiers, separated by ``;``) and ``n_buildings`` follow.
        """
        m = self.metres_per_unit
        t = self.blocks
        me = self.measures
        faces = self.surface.face_count_per_block(int(t.block_id.max()) if len(t) else 0)
        z0 = self.grid.offset[2]
        rows = []
        for b in range(len(t)):
            index = t.block_id[b] - 1
            rows.append({
                "block_id": int(t.block_id[b]),
                "height": float(t.height[b] * m),
                "ground_z": float(t.ground_z[b] + z0),
                "top_z": float(t.top_z[b] + z0),
                "footprint_area": float(t.footprint_area[b] * m**2),
                "volume": float(t.volume[b] * m**3),
                "surface_area": float(faces[index] * (self.grid.voxel_size * m) ** 2),
                "n_voxels": int(t.n_voxels[b]),
                "mesh_volume": float(me.volume[index] * m**3),
                "mesh_area": float(me.area[index] * m**2),
                "roof_area": float(me.roof_area[index] * m**2),
                "facade_area": float(me.facade_area[index] * m**2),
                "min_quality": float(me.min_quality[index]),
                "mean_quality": float(me.mean_quality[index]),
                "mean_dist": _plain(me.mean_dist[index] * m),
                "max_dist": _plain(me.max_dist[index] * m),
            })
            if self.block_buildings is not None:
                rows[-1]["building_ids"] = ";".join(self.block_buildings[b])
                rows[-1]["n_buildings"] = len(self.block_buildings[b])
        return rows

    def block_surface_wkb(self) -> Iterator[bytes]:
        """Closed outward surface of every block as MultiPolygonZ WKB, world
        coordinates, in the order of :attr:`blocks`: made as they are taken
        (:func:`core.wkb.multipolygons_z`), so that a writer holds one at a time.

        Voxel faces are written as quads; once smoothed, as the two
        triangles of each quad's best split (a moved quad is not planar).
        """
        from .wkb import multipolygons_z

        with reusing_freed_memory():
            ids = self.blocks.block_id
            lookup = np.full(int(ids.max()) + 2 if len(ids) else 1, -1, dtype=np.int64)
            lookup[ids] = np.arange(len(ids))
            faces, owner = self._layer_faces(self.mesh.on_block()).block_faces()
            index = lookup[owner]
            order = stable_order(index, len(ids))
            # take: row gathers faster than indexing (core.vectors).
            faces, index = faces.take(order, axis=0), index[order]
            del owner, order, lookup  # not held while the layer is written
            yield from multipolygons_z(self.mesh.nodes, faces, index, len(ids), offset=self.grid.offset)

    def ground_surface_wkb(self, tile: int = 64) -> Iterator[bytes]:
        """The terrain (ground/air faces) as MultiPolygonZ WKB, one per tile of
        ``tile`` x ``tile`` columns so that no feature is city-sized; made as
        they are taken, as :meth:`block_surface_wkb`."""
        from .surface import AIR_REGION, GROUND_REGION, unique_pairs
        from .wkb import multipolygons_z

        with reusing_freed_memory():
            a, b = self.mesh.regions[:, 0], self.mesh.regions[:, 1]
            model = self._layer_faces(((a == GROUND_REGION) & (b == AIR_REGION))
                                      | ((a == AIR_REGION) & (b == GROUND_REGION)))
            faces = model.interface(GROUND_REGION, AIR_REGION)
            if len(faces) == 0:
                return
            # Each face's centre in x and y, its corners summed in order as a
            # mean over them sums them: no (F, k, 3) table of its corners.
            centre = np.empty((len(faces), 2))
            for axis in range(2):
                coordinate = np.ascontiguousarray(model.nodes[:, axis])
                total = coordinate.take(faces[:, 0])
                for corner in range(1, faces.shape[1]):
                    total += coordinate.take(faces[:, corner])
                centre[:, axis] = total / faces.shape[1]
            key = np.floor((centre - self.grid.origin[:2]) / (tile * self.grid.voxel_size)).astype(np.int64)
            tiles, index = unique_pairs(key)
            order = stable_order(index, len(tiles))
            faces, index = faces.take(order, axis=0), index[order]
            del centre, key, order  # not held while the layer is written
            yield from multipolygons_z(model.nodes, faces, index, len(tiles), offset=self.grid.offset)

    def _layer_faces(self, keep: np.ndarray) -> SurfaceModel:
        """The faces ``keep`` of ``mesh`` as the layers draw them: its quads
        while no node has moved (voxel faces are planar), else their
        triangles in :attr:`mesh_triangles`, made for these faces alone
        unless that is made already (each quad is split on its own).

        The layers draw half of the model's faces (none of the domain's
        box): on the 1 km city the two layers triangulate 1.8 M and 0.7 M of
        its 4.9 M quads, each on its own thread, where the whole model's
        triangles took 0.6-0.9 s and were then held as long as the result.
        """
        if self.mesh.nodes is self.surface.nodes:
            return self.mesh.selected(keep)
        if self._triangles is not None:
            return self._triangles.selected(np.repeat(keep, 2))  # triangles 2 f and 2 f + 1 split face f
        return self._triangulated(keep)

    def _triangulated(self, keep: np.ndarray | None = None) -> SurfaceModel:
        """The faces ``keep`` (all if None) of ``mesh``, triangulated; the
        block faces along the diagonals the measures chose
        (:attr:`block_diagonal`): the blocks layer splits none itself (0.1 s
        of its 0.85 s on the 1 km city)."""
        model = self.mesh if keep is None else self.mesh.selected(keep)
        if self.block_diagonal is None:
            return model.triangulated()
        block = self.mesh.on_block()
        on_block = block if keep is None else block[keep]
        diagonal = np.empty(len(model.quads), dtype=bool)
        diagonal[on_block] = self.block_diagonal if keep is None else self.block_diagonal[keep[block]]
        if not on_block.all():
            from .quality import best_diagonal

            diagonal[~on_block] = best_diagonal(model.nodes, model.quads.compress(~on_block, axis=0))
        return model.triangulated(diagonal)

    @property
    def mesh_triangles(self) -> SurfaceModel:
        """``mesh`` with every quad split along its best diagonal, made once
        for the mesh files (the layers take their faces from it once it is
        made, :meth:`_layer_faces`)."""
        if self._triangles is None:
            # Its block-sized temporaries reuse freed memory, as in the run:
            # with glibc's defaults each is fresh pages (the 1 km city's
            # first PLY took 7 s, 6 of them in the kernel).
            with reusing_freed_memory():
                self._triangles = self._triangulated()
        return self._triangles

    @reusing_freed_memory()
    def write_mesh(self, path, binary: bool = False, is_cancelled=None) -> "Path":
        """Write the final conforming mesh; the suffix picks the format, ``binary``
        the encoding of a ``.msh``; a cancel stops it between blocks of rows and
        leaves no file (:func:`core.export.write_mesh`)."""
        from .export import write_mesh

        return write_mesh(path, self.mesh, self.grid.offset, binary=binary, triangles=self.mesh_triangles,
                          is_cancelled=is_cancelled)

    def write_preview(self, path, before_after: bool = True, is_cancelled=None) -> "Path":
        """PNG picture, blocks coloured by height; voxels beside the final mesh
        (a cancel stops it between the panels, :func:`core.preview.write_preview`)."""
        from .preview import write_preview

        heights = {row["block_id"]: row["height"] for row in self.block_rows()}
        panels = [(self.mesh, "smoothed and projected (§4)")]
        if before_after:
            panels.insert(0, (self.surface, "voxel model (§3)"))
        return write_preview(path, panels, heights, is_cancelled=is_cancelled)

    def footprint_wkb(self) -> list[bytes]:
        """Footprint of every block (the outline of its columns, :mod:`core.footprint`)
        as Polygon WKB, in the order of :attr:`blocks`."""
        import shapely

        from .footprint import column_outlines

        corner = self.grid.offset[:2] + self.grid.origin[:2]
        outlines = column_outlines(self.footprint_columns, np.asarray(self.blocks.block_id), corner,
                                   self.grid.voxel_size)
        return list(shapely.to_wkb(outlines, output_dimension=2))  # GEOS < 3.12 in QGIS: no 4D


def _plain(value: float) -> float | None:
    """A Python float, or None (a NULL field) for NaN."""
    return None if not np.isfinite(value) else float(value)
