"""What a run writes besides the core: the files its outputs make, so that a cancel or an error while
they are written leaves none half-written, and the check of the mesh file's name before the run.

The layers are written one after the other after the method, and the mesh file meanwhile on a
thread of its own (see :mod:`.base`): a cancel or an error at 90 % would otherwise leave a
GeoPackage with some of the blocks and no footprints. :class:`RunOutputs` records each output as
it is opened and removes them all when the writing does not end: a file the run made or
overwrote is deleted, and a layer the run added to a GeoPackage that held other layers before is
dropped from it (the file and its other layers stay).
"""

import os

from qgis.core import QgsDataSourceUri, QgsProviderRegistry

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
