"""What a run writes once the core has returned: the blocks, footprints and ground layers, the mesh
file and its picture (:class:`OutputWriter`); the files they make, so that a cancel or an error while
they are written leaves none half-written (:class:`RunOutputs`); and the check of the mesh file's name
before the run.

The layers are written one after the other after the method, and the mesh file meanwhile on a
thread of its own (see :mod:`.base`): a cancel or an error at 90 % would otherwise leave a
GeoPackage with some of the blocks and no footprints. :class:`RunOutputs` records each output as
it is opened and removes them all when the writing does not end: a file the run made or
overwrote is deleted, and a layer the run added to a GeoPackage that held other layers before is
dropped from it (the file and its other layers stay).
"""

import math
import os
from concurrent.futures import ThreadPoolExecutor

from qgis.core import (
    QgsCoordinateReferenceSystem,
    QgsDataSourceUri,
    QgsFeature,
    QgsFeatureSink,
    QgsFields,
    QgsProcessingException,
    QgsProviderRegistry,
)

from ..compat import MULTIPOLYGON_Z, POLYGON, make_field
from ..styles import style_blocks, style_footprints, style_ground, style_on_load
from .geometries import GeometryFeed

#: Share of the progress bar (%) for the method; writing the outputs has the rest.
RECONSTRUCTION_PERCENT = 80.0

#: Fields every block has, in this order, as (name, kind); kind is "int", "long", "double" or
#: "string": those of the voxel model, then the measures of the smoothed mesh (the keys of
#: core.reconstruction.Reconstruction.block_rows).
BLOCK_FIELDS = (
    ("block_id", "int"),
    ("height", "double"),
    ("ground_z", "double"),
    ("top_z", "double"),
    ("footprint_area", "double"),
    ("volume", "double"),
    ("surface_area", "double"),
    ("n_voxels", "long"),
    ("mesh_volume", "double"),
    ("mesh_area", "double"),
    ("roof_area", "double"),
    ("facade_area", "double"),
    ("min_quality", "double"),
    ("mean_quality", "double"),
    ("mean_dist", "double"),
    ("max_dist", "double"),
)

#: The fields that follow where the input is a city model that names its buildings (the
#: result's block_buildings is set, whether or not any block is left).
CITY_FIELDS = (
    ("building_ids", "string"),
    ("n_buildings", "long"),
)

def field_kinds(rows, city_model=False):
    """(name, kind) of the output fields: :data:`BLOCK_FIELDS`, :data:`CITY_FIELDS` for a
    ``city_model``, then any other keys of the rows, in order.

    The layers have the same fields whatever the number of blocks: an empty result's are
    those of a full one (the rows only add keys a newer core may give).
    """
    kinds = list(BLOCK_FIELDS) + (list(CITY_FIELDS) if city_model else [])
    known = {name for name, _ in kinds}
    for name, value in rows[0].items() if rows else ():
        if name not in known:
            kind = ("string" if isinstance(value, str)
                    else "long" if isinstance(value, int) and not isinstance(value, bool) else "double")
            kinds.append((name, kind))
    return kinds


def block_fields(kinds):
    """The :class:`QgsFields` for ``kinds`` (see :func:`field_kinds`)."""
    fields = QgsFields()
    for name, kind in kinds:
        fields.append(make_field(name, kind))
    return fields


def block_attributes(row, kinds):
    """Attribute values of a core block row as plain Python int/float/str (numpy scalars break
    GPKG writes); missing or non-finite values become NULL."""
    values = []
    for name, kind in kinds:
        value = row.get(name)
        if kind == "string":
            values.append(None if value is None else str(value))
        elif value is None or not math.isfinite(value):
            values.append(None)
        else:
            values.append(int(value) if kind != "double" else float(value))
    return values

#: The suffixes of the mesh file (core.export.MESH_FORMATS, which the tests compare them to):
#: checked before the run, which is long, rather than by the core's writer once it is over.
MESH_SUFFIXES = (".msh", ".vtu", ".obj", ".stl", ".ply")

#: Files that a GeoPackage or SQLite database has beside it while it is open.
_JOURNALS = ("-wal", "-shm", "-journal")

#: The files of a shapefile besides the .shp (GDAL writes .cpg and .prj; QGIS may add .qix, .qmd).
_SHAPEFILE_PARTS = (".shx", ".dbf", ".prj", ".cpg", ".qpj", ".qix", ".qmd", ".sbn", ".sbx")


def mesh_path_problem(path, tr):
    """What is wrong with ``path`` as the mesh file, translated by ``tr``; None if nothing."""
    suffix = os.path.splitext(path)[1].lower()
    if suffix not in MESH_SUFFIXES:
        return tr("The mesh file {} has no mesh extension: end its name with one of {} (the extension picks "
                  "the format).").format(path, ", ".join(MESH_SUFFIXES))
    if os.path.isdir(path):
        return tr("The mesh file {} is a folder: give a file name inside it.").format(path)
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        return tr("The folder of the mesh file {} does not exist: create it or choose another one.").format(path)
    if not os.access(folder, os.W_OK | os.X_OK):
        return tr("The folder of the mesh file {} cannot be written to: choose another one.").format(path)
    return None


def layer_file(destination):
    """``(path, layer name or None)`` of a sink's destination (a file path, ``path|layername=...``
    or ``ogr:dbname=... table=...``); ``(None, None)`` when it is not a local file (a memory
    layer's id, a database)."""
    if destination.startswith("ogr:"):
        uri = QgsDataSourceUri(destination[len("ogr:"):])
        path, layer = uri.database(), uri.table() or None
    else:
        parts = QgsProviderRegistry.instance().decodeUri("ogr", destination)
        path, layer = parts.get("path") or "", parts.get("layerName") or None
    if not path or not os.path.isabs(path):
        return None, None
    return path, layer


class RunOutputs:
    """The files and layers one run writes, to remove them if the writing does not end.

    :meth:`opening` is told of each layer output before it is opened (a file that exists
    then keeps its other layers), :meth:`opened` once it is, and :meth:`file` of every
    other file the run writes; :meth:`remove` deletes what they name.
    """

    def __init__(self):
        self._existed = set()  # the files of layer outputs that were there before this run
        self._layers = []  # (path, layer name or None) of every layer output opened
        self._files = []  # other files this run writes

    def opening(self, destination):
        """Note whether the file of the layer output ``destination`` (as the user gave it) is
        there before it is opened: not made by this run, it keeps its other layers."""
        path, _ = layer_file(destination)
        ours = {opened for opened, _ in self._layers}  # a file an earlier output of this run made
        if path and path not in self._existed and path not in ours and os.path.isfile(path):
            self._existed.add(path)

    def opened(self, destination):
        """Note the layer output opened at ``destination`` (as the sink gives it)."""
        path, layer = layer_file(destination)
        if path:
            self._layers.append((path, layer))

    def file(self, path):
        """Note a file the run writes (the mesh, its picture)."""
        self._files.append(path)

    def remove(self):
        """Remove what the run wrote; returns the paths of what could not be removed."""
        left = []
        dropped = {}
        for path, layer in self._layers:
            if path in self._existed and layer is not None:
                dropped.setdefault(path, []).append(layer)  # the file had layers of its own: drop ours
            else:
                left += _delete(path, _SHAPEFILE_PARTS if path.lower().endswith(".shp") else ())
        for path, layers in dropped.items():
            if not _drop_layers(path, layers):
                left.append(path)
        for path in self._files:
            left += _delete(path, ())
        return left


def _drop_layers(path, layers):
    """Delete ``layers`` from the vector file ``path``; whether it went well."""
    from osgeo import ogr

    dataset = ogr.Open(path, 1)
    if dataset is None:
        return False
    for name in layers:
        for index in range(dataset.GetLayerCount()):
            if dataset.GetLayerByIndex(index).GetName() == name:
                if dataset.DeleteLayer(index) != 0:
                    return False
                break
    dataset = None  # closes it, committing the deletion
    return True


def _delete(path, parts):
    """Delete ``path``, its journals and the ``parts`` beside it (suffixes replacing its own);
    returns those that are still there."""
    stem = os.path.splitext(path)[0]
    left = []
    for name in [path] + [path + journal for journal in _JOURNALS] + [stem + suffix for suffix in parts]:
        try:
            os.remove(name)
        except FileNotFoundError:
            pass
        except OSError:
            left.append(name)
    return left


class OutputWriter:
    """The writing of a run's outputs, for :class:`~.base.UrbanvoxAlgorithm` (a Processing
    algorithm with its OUTPUT_* parameters and :meth:`meshPath`)."""

    def writeOutputs(self, result, parameters, context, feedback):  # noqa: N802
        """Write the layers, the mesh file and its picture; a cancel or an error on the way
        removes what they wrote (:class:`RunOutputs`) and raises."""
        # A city's layers, mesh and picture take a while after the method: they have their share
        # of the progress bar.
        feedback.setProgress(RECONSTRUCTION_PERCENT)
        feedback.setProgressText(self.tr("Writing the blocks and footprints"))
        mesh_path = self.meshPath(parameters, context)
        binary = self.parameterAsBoolean(parameters, self.MESH_BINARY, context)
        written = RunOutputs()
        try:
            # The mesh file and its picture are written on a thread of their own
            # while this one writes the layers (QGIS's and GDAL's C++, the GIL
            # released): the 1 km synthetic city's outputs with a .msh took
            # 8.3-9.4 s in a qgis_process run one after the other, 7.1-8.2 s so.
            # Leaving waits for it, whatever the layers did: what it wrote is
            # known before anything is removed.
            with ThreadPoolExecutor(max_workers=1, thread_name_prefix="urbanvox-mesh") as mesh_thread:
                mesh_written = mesh_thread.submit(self._write_mesh, result, mesh_path, binary, written,
                                                  feedback.isCanceled) if mesh_path else None
                outputs = self._write_layers(result, parameters, context, feedback, written)
                if mesh_written is not None:
                    feedback.setProgress(92.0)
                    feedback.setProgressText(self.tr("Writing the mesh {}").format(os.path.basename(mesh_path)))
                    try:
                        preview = mesh_written.result()
                    except _Cancelled:
                        raise
                    except Exception as err:  # UrbanvoxError, or an I/O error: say which file
                        raise QgsProcessingException(self.tr("Could not write {}: {}").format(mesh_path, err)) \
                            from err
                    outputs[self.OUTPUT_MESH] = mesh_path
                    outputs[self.OUTPUT_PREVIEW] = preview
            if feedback.isCanceled():
                raise _Cancelled()
        except BaseException as err:
            left = written.remove()
            if left:
                feedback.reportError(self.tr("Could not remove the outputs written before the run stopped: {}")
                                     .format(", ".join(left)))
            if isinstance(err, _Cancelled):
                raise QgsProcessingException(self.tr("Cancelled; no output was written.")) from None
            raise
        if mesh_path:
            feedback.pushInfo(self.tr("Mesh written to {}, preview to {}.").format(mesh_path, preview))

        count = int(result.summary["block_count"])
        volume = float(result.summary["total_volume"])
        feedback.setProgress(100.0)
        feedback.pushInfo(self.tr("{} building blocks, total volume {:.1f} m³.").format(count, volume))
        style_on_load(context, outputs[self.OUTPUT_BLOCKS], style_blocks)
        style_on_load(context, outputs[self.OUTPUT_FOOTPRINTS], style_footprints)
        style_on_load(context, outputs.get(self.OUTPUT_GROUND), style_ground)
        outputs.update({self.BLOCK_COUNT: count, self.TOTAL_VOLUME: volume})
        return outputs

    def _write_layers(self, result, parameters, context, feedback, written):
        """Write the blocks, footprints and (if asked for) ground layers, each noted in ``written``
        (:class:`RunOutputs`); returns their destinations."""
        rows = result.block_rows()
        crs = QgsCoordinateReferenceSystem.fromWkt(result.crs.to_wkt())
        kinds = field_kinds(rows, city_model=getattr(result, "block_buildings", None) is not None)
        fields = block_fields(kinds)
        attributes = [block_attributes(row, kinds) for row in rows]
        destinations = {}
        # The layers' geometries are made on a thread of their own while this
        # one writes them (core.wkb, then QGIS's parse; see .geometries): the
        # 1 km synthetic city's three layers into GeoPackages (550 MB of WKB)
        # took 9.4 s one step after the other, 5.5-5.8 s so.
        ground = bool(parameters.get(self.OUTPUT_GROUND))
        sources = [result.block_surface_wkb, result.footprint_wkb] + ([result.ground_surface_wkb] if ground else [])
        with GeometryFeed(*sources) as feed:
            # One layer after the other, each closed before the next is opened:
            # several outputs are often layers of one GeoPackage, and two open
            # writers of one file can lose a layer when they commit.
            for layer, (name, wkb_type, percent) in enumerate((
                    (self.OUTPUT_BLOCKS, MULTIPOLYGON_Z, (RECONSTRUCTION_PERCENT, 87.0)),
                    (self.OUTPUT_FOOTPRINTS, POLYGON, (87.0, 88.0)))):
                features = ((attributes[i] if i < len(attributes) else [None] * len(kinds), geometry)
                            for i, geometry in enumerate(feed.layer(layer)))
                destinations[name], count = self._write_layer(parameters, name, context, fields, wkb_type, crs,
                                                              features, feed, feedback, percent, len(rows), written)
                if count != len(rows):
                    raise QgsProcessingException(f"Internal error: {len(rows)} blocks, {count} features in {name}.")
            if ground:
                feedback.setProgress(88.0)
                feedback.setProgressText(self.tr("Writing the ground"))
                ground_fields = QgsFields()
                ground_fields.append(make_field("tile", "int"))
                tiles = (([tile], geometry) for tile, geometry in enumerate(feed.layer(2)))
                ground_destination, _ = self._write_layer(parameters, self.OUTPUT_GROUND, context, ground_fields,
                                                          MULTIPOLYGON_Z, crs, tiles, feed, feedback, (88.0, 92.0), 0,
                                                          written, optional=True)
                if ground_destination is not None:
                    destinations[self.OUTPUT_GROUND] = ground_destination
        return destinations

    def _write_layer(self, parameters, name, context, fields, wkb_type, crs, rows, feed, feedback, percent, count,
                     written, optional=False):
        """Write ``rows`` of (attributes, geometry) to output ``name`` and close it;
        each geometry goes back to ``feed`` once written, the output is noted in
        ``written`` (:class:`RunOutputs`) once opened.

        Returns its destination and the number of features written. The
        progress bar goes from ``percent[0]`` to ``percent[1]`` over ``count``
        rows (0: unknown, it stays). An ``optional`` output the user left out
        gives ``(None, 0)``. A cancel stops it between two features: it raises
        :class:`_Cancelled`, the sink closed.
        """
        if feedback.isCanceled():
            raise _Cancelled()
        written.opening(_sink_value(parameters.get(name), context))
        sink, destination = self.parameterAsSink(parameters, name, context, fields, wkb_type, crs)
        if sink is None:
            if optional:
                return None, 0
            raise QgsProcessingException(self.invalidSinkError(parameters, name))
        written.opened(destination)
        start, end = percent
        every = max(1, count // 50)
        added = 0
        try:
            for attributes, geometry in rows:
                self._add(sink, fields, attributes, geometry, name)
                feed.written(geometry)
                added += 1
                if feedback.isCanceled():
                    raise _Cancelled()
                if count and added % every == 0:
                    feedback.setProgress(start + (end - start) * added / count)
            if not sink.flushBuffer():
                raise QgsProcessingException(self.tr("Could not write {}: {}").format(name, sink.lastError()))
        finally:
            # The writer closes, whatever happened: its file is complete before the next output
            # opens it, or can be removed.
            del sink
        return destination, added

    @staticmethod
    def _write_mesh(result, path, binary, written, is_cancelled):
        """Write the mesh file ``path`` and its preview picture beside it, each noted in ``written``
        once there; returns the picture's path. A cancel stops either on the way and leaves no file
        of it (the core writes the mesh into a temporary, renamed when complete, and checks the
        cancel between blocks of rows; the picture between its panels)."""
        from ...core.errors import Cancelled

        try:
            result.write_mesh(path, binary=binary, is_cancelled=is_cancelled)
            written.file(path)
            preview = os.path.splitext(path)[0] + ".png"
            result.write_preview(preview, is_cancelled=is_cancelled)
        except Cancelled:
            raise _Cancelled() from None
        written.file(preview)
        return preview

    @staticmethod
    def _add(sink, fields, attributes, geometry, name):
        feature = QgsFeature(fields)
        feature.setAttributes(attributes)
        feature.setGeometry(geometry)
        if not sink.addFeature(feature, QgsFeatureSink.Flag.FastInsert):
            raise QgsProcessingException(f"Could not write block {attributes[0]} to {name}: {sink.lastError()}")


class _Cancelled(Exception):
    """A cancel while the outputs are written: what was written is removed, then the run stops."""


def _sink_value(value, context):
    """A sink parameter's value as the user gave it: a path, URI, ``memory:`` or ``TEMPORARY_OUTPUT``."""
    from qgis.core import QgsProcessingOutputLayerDefinition

    if isinstance(value, QgsProcessingOutputLayerDefinition):
        value, _ = value.sink.valueAsString(context.expressionContext(), "")
    return value if isinstance(value, str) else ""
