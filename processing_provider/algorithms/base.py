"""What both reconstruction algorithms share: parameters, dependency check, core call, outputs.

A subclass adds its input parameters (:meth:`UrbanvoxAlgorithm.addInputParameters`)
and runs the core (:meth:`UrbanvoxAlgorithm.reconstruct`); this class adds the
voxel and threshold parameters, turns the core's progress, cancel and errors into
Processing's, and writes the outputs (:mod:`.outputs`). The sinks are created only
after the core has returned; a cancel or an error while they are written removes
what this run wrote, so no half-written output is left.
"""

import importlib.util
import os
import re
import sys

from qgis.core import (
    QgsCoordinateReferenceSystem,
    QgsCoordinateTransform,
    QgsCsException,
    QgsProcessingAlgorithm,
    QgsProcessingException,
    QgsProcessingOutputFile,
    QgsProcessingOutputNumber,
    QgsProcessingParameterBoolean,
    QgsProcessingParameterCrs,
    QgsProcessingParameterExtent,
    QgsProcessingParameterFeatureSink,
    QgsProcessingParameterFileDestination,
    QgsProcessingParameterNumber,
    QgsProcessingParameterString,
)
from qgis.PyQt.QtCore import QCoreApplication
from qgis.PyQt.QtGui import QIcon

from .. import ICON_PATH
from ..compat import FLAG_ADVANCED, NUMBER_DOUBLE, NUMBER_INTEGER, VECTOR_POLYGON
from .outputs import RECONSTRUCTION_PERCENT, OutputWriter, mesh_path_problem

#: Python packages every algorithm needs; subclasses add their readers'.
BASE_MODULES = ("numpy", "scipy", "pyproj", "shapely")

#: What a user installs into QGIS's Python to get all of them (numba: optional, faster).
PIP_PACKAGES = ('"laspy[lazrs]"', "trimesh", "shapely", "pyproj", "scipy", "numba")

#: The core's progress text as it starts to cut the domain into tiles (core.tiles.reconstruct_tiled):
#: only then are Dask's workers or scheduler used.
_TILING_MESSAGE = "Cutting the domain into tiles"

#: A parameter named with its command-line flag in a core message: ``FILL_UNDER_ROOFS (--fill-under-roofs)``.
_FLAG_NAMED = re.compile(r"\b([A-Z][A-Z_]+) \(--[a-z][a-z-]*\)")

#: Seconds from a dialog's opening to the compiled kernels' loading (createCustomParametersWidget):
#: the dialog builds first, as the loading holds Python's GIL most of its time.
_DIALOG_SETTLE_S = 0.5


def pip_command():
    """The pip command that installs the dependencies into the Python running QGIS."""
    # sys.executable is the QGIS binary (or whatever "python3" is first on PATH) inside QGIS:
    # name the interpreter QGIS embeds instead.
    python = os.path.join(sys.exec_prefix, "bin", "python{}.{}".format(*sys.version_info[:2]))
    if os.name == "nt" or not os.path.exists(python):
        python = "python"  # Windows: in the OSGeo4W Shell
    packages = list(PIP_PACKAGES)
    try:
        import numpy

        packages.append(f'"numpy=={numpy.__version__}"')  # never let pip upgrade QGIS's numpy
    except ImportError:
        pass
    return f"{python} -m pip install --user {' '.join(packages)}"


def missing_dependency_message(modules):
    """The user-facing message for missing Python packages ``modules``."""
    return (
        f"urbanvox needs Python package(s) that the Python used by QGIS cannot import: {', '.join(modules)}. "
        f"Install them with:\n    {pip_command()}\n"
        "(Debian/Ubuntu: add --break-system-packages; Windows: run it in the OSGeo4W Shell), then restart QGIS."
    )


class UrbanvoxAlgorithm(OutputWriter, QgsProcessingAlgorithm):
    """Base class of the reconstruction algorithms (see the module docstring)."""

    INPUT = "INPUT"
    CRS = "CRS"
    VOXEL_SIZE = "VOXEL_SIZE"
    MIN_HEIGHT = "MIN_HEIGHT"
    MIN_FOOTPRINT = "MIN_FOOTPRINT"
    MIN_VOLUME = "MIN_VOLUME"
    EXTENT = "EXTENT"
    SMOOTHING_ITERATIONS = "SMOOTHING_ITERATIONS"
    PROJECT = "PROJECT"
    QUALITY_THRESHOLD = "QUALITY_THRESHOLD"
    TILE_SIZE = "TILE_SIZE"
    WORKERS = "WORKERS"
    SCHEDULER = "SCHEDULER"
    MESH_BINARY = "MESH_BINARY"
    OUTPUT_BLOCKS = "OUTPUT_BLOCKS"
    OUTPUT_FOOTPRINTS = "OUTPUT_FOOTPRINTS"
    OUTPUT_GROUND = "OUTPUT_GROUND"
    OUTPUT_MESH = "OUTPUT_MESH"
    OUTPUT_PREVIEW = "OUTPUT_PREVIEW"
    BLOCK_COUNT = "BLOCK_COUNT"
    TOTAL_VOLUME = "TOTAL_VOLUME"

    #: Help shared by both algorithms, appended to the subclass's own.
    COMMON_HELP = (
        "<p>The data are put in a grid of cubic voxels; voxels are sorted into ground, building and air "
        "(air is flood-filled from above, so closed courtyards and inner surfaces are handled); "
        "face-connected building voxels form a building block. Blocks lower, smaller or lighter than the "
        "thresholds are dropped.</p>"
        "<p><b>Voxel size</b>: edge of a voxel in metres; halving it multiplies memory and time by ~8.<br>"
        "<b>Minimum height / footprint / volume</b>: blocks below any of them are discarded.<br>"
        "<b>Smoothing passes</b>: vertex-only Catmull-Clark passes (paper: 3); nodes at the foot of the walls "
        "keep their height. <b>Project</b>: move the smoothed nodes onto moving-least-squares planes of the "
        "data. <b>Minimum face quality</b>: a smoothing or projection move that would leave a worse face is "
        "refused (a voxel face scores 0.72).<br>"
        "<b>Domain extent</b>: clip the data; blocks crossing it are closed on its sides.</p>"
        "<p><b>Blocks</b>: one MultiPolygonZ per block, its closed outer surface (smoothed and projected). "
        "<b>Footprints</b>: one polygon per block (the columns it covers). Both have the fields block_id, "
        "height, ground_z, top_z, footprint_area (m²), volume (m³), surface_area (m²) and n_voxels of the "
        "voxel model, then mesh_volume, mesh_area, roof_area, facade_area, min_quality, mean_quality, "
        "mean_dist and max_dist (m, nodes to the data) of the final mesh. <b>Ground surface</b>: the "
        "terrain, in tiles. <b>Mesh file</b>: closed, conforming surfaces of every block, the ground and the "
        "air; the extension picks the format (.msh with physical groups per interface and per region, .vtu, "
        ".obj, .stl, .ply); a PNG preview is written beside it.</p>"
    )

    def tr(self, text):
        return QCoreApplication.translate("urbanvox", text)

    def createInstance(self):  # noqa: N802 (QGIS API name)
        return type(self)()

    def createCustomParametersWidget(self, parent=None):  # noqa: N802 (QGIS API name)
        """None, so QGIS builds its own dialog. QGIS asks when it opens the dialog (the
        toolbox, the locator, the menus; not qgis_process, a model or a batch): while the
        user fills it in, the compiled kernels load on a thread of their own, and the
        session's first run does not wait for numba (about 0.5 s: Delft at 0.5 m takes
        0.6-0.7 s of method in a process's later runs)."""
        from ...core import jit  # the standard library only; numba, if missing, is skipped

        jit.preload(after=_DIALOG_SETTLE_S)
        return None

    def icon(self):
        return QIcon(ICON_PATH)

    def group(self):
        return ""

    #: Words the toolbox's search finds the algorithm by, besides its name (comma-separated,
    #: translated): the method's, and those of the algorithm's input.
    TAGS = "voxel,building,block,urban,city,3d,finite element,cfd,mesh,gmsh,catmull-clark"
    INPUT_TAGS = ""

    def tags(self):
        words = ",".join(self.tr(text) for text in (self.TAGS, self.INPUT_TAGS) if text)
        return [word.strip() for word in words.split(",")]

    def groupId(self):  # noqa: N802 (QGIS API name)
        return ""

    # -- parameters ---------------------------------------------------------------------------

    def addInputParameters(self):  # noqa: N802
        """Add the algorithm's own input parameters (subclasses)."""
        raise NotImplementedError

    def addCrsParameter(self, description, optional):  # noqa: N802
        self.addParameter(QgsProcessingParameterCrs(self.CRS, self.tr(description), optional=optional))

    def initAlgorithm(self, config=None):  # noqa: N802 (QGIS API name)
        self.addInputParameters()
        for name, description, default, minimum in (
            (self.VOXEL_SIZE, "Voxel size (m)", 1.0, 0.05),
            (self.MIN_HEIGHT, "Minimum block height (m)", 2.5, 0.0),
            (self.MIN_FOOTPRINT, "Minimum block footprint (m²)", 10.0, 0.0),
            (self.MIN_VOLUME, "Minimum block volume (m³)", 20.0, 0.0),
        ):
            self.addParameter(
                QgsProcessingParameterNumber(
                    name, self.tr(description), type=NUMBER_DOUBLE, defaultValue=default, minValue=minimum
                )
            )
        extent = QgsProcessingParameterExtent(self.EXTENT, self.tr("Domain extent (default: the data's)"),
                                              optional=True)
        extent.setFlags(extent.flags() | FLAG_ADVANCED)
        self.addParameter(extent)
        self.addParameter(
            QgsProcessingParameterNumber(self.SMOOTHING_ITERATIONS, self.tr("Smoothing passes (Catmull-Clark)"),
                                         type=NUMBER_INTEGER, defaultValue=3, minValue=0, maxValue=20)
        )
        self.addParameter(
            QgsProcessingParameterBoolean(self.PROJECT, self.tr("Project the smoothed surfaces onto the data"),
                                          defaultValue=True)
        )
        quality = QgsProcessingParameterNumber(
            self.QUALITY_THRESHOLD, self.tr("Minimum face quality (inradius / longest edge, 1 = equilateral)"),
            type=NUMBER_DOUBLE, defaultValue=0.2, minValue=0.0, maxValue=0.7)
        quality.setFlags(quality.flags() | FLAG_ADVANCED)
        self.addParameter(quality)
        for parameter in (
            QgsProcessingParameterNumber(self.TILE_SIZE, self.tr("Tile size (m, 0 = one grid)"),
                                         type=NUMBER_DOUBLE, defaultValue=0.0, minValue=0.0),
            QgsProcessingParameterNumber(self.WORKERS, self.tr("Worker processes for the tiles (Dask)"),
                                         type=NUMBER_INTEGER, defaultValue=0, minValue=0, maxValue=256),
            QgsProcessingParameterString(self.SCHEDULER, self.tr("Dask scheduler address (default: local workers)"),
                                         optional=True),
            QgsProcessingParameterBoolean(self.MESH_BINARY, self.tr("Write a .msh mesh file in binary"),
                                          defaultValue=False),
        ):
            parameter.setFlags(parameter.flags() | FLAG_ADVANCED)
            self.addParameter(parameter)
        # Temporary outputs are GeoPackages in QGIS's temporary folder, not
        # memory layers: a memory layer holds its geometries as QGIS's objects,
        # 4-5 times their WKB, for as long as it is open (a qgis_process run of
        # the 1 km synthetic city: 3.8 GB at its peak against 2.3 GB, about the
        # method's own). A memory layer asked for by name (``memory:``) is
        # still made.
        for sink in (
            QgsProcessingParameterFeatureSink(self.OUTPUT_BLOCKS, self.tr("Building blocks (3D surfaces)"),
                                              VECTOR_POLYGON),
            QgsProcessingParameterFeatureSink(self.OUTPUT_FOOTPRINTS, self.tr("Building footprints"), VECTOR_POLYGON),
            QgsProcessingParameterFeatureSink(self.OUTPUT_GROUND, self.tr("Ground surface"), VECTOR_POLYGON,
                                              optional=True, createByDefault=False),
        ):
            sink.setSupportsNonFileBasedOutput(False)
            self.addParameter(sink)
        self.addParameter(
            QgsProcessingParameterFileDestination(
                self.OUTPUT_MESH, self.tr("Conforming mesh file (blocks, ground, air)"),
                self.tr("gmsh (*.msh);;VTK unstructured grid (*.vtu);;Wavefront OBJ (*.obj);;"
                        "STL, one solid per region (*.stl);;PLY (*.ply)"),
                optional=True, createByDefault=False)
        )
        self.addOutput(QgsProcessingOutputFile(self.OUTPUT_PREVIEW, self.tr("Preview picture (PNG)")))
        self.addOutput(QgsProcessingOutputNumber(self.BLOCK_COUNT, self.tr("Number of building blocks")))
        self.addOutput(QgsProcessingOutputNumber(self.TOTAL_VOLUME, self.tr("Total volume of the blocks (m³)")))
        for name, text in {**self.PARAMETER_HELP, **self.INPUT_HELP}.items():
            definition = self.parameterDefinition(name)
            if definition is not None:
                definition.setHelp(self.tr(text))

    #: Help of the parameters an algorithm words its own way (its input's), over PARAMETER_HELP.
    INPUT_HELP: dict = {}

    #: Tooltip help of every parameter (shown in the dialog and by ``qgis_process help``).
    PARAMETER_HELP = {
        "GROUND_CLASSES": "ASPRS classification codes of the ground points, comma-separated (standard: 2).",
        "BUILDING_CLASSES": "Classification codes of the building points, comma-separated (standard: 6); "
                            "vegetation, noise and other codes are ignored.",
        "GROUND": "Optional terrain mesh, or a CityJSON file's terrain (TINRelief); without it the ground is a "
                  "CityJSON input's own terrain, else it passes through the bottom of every building part.",
        "LOD": "The level of detail a CityJSON file's buildings are taken at where they have it, as the file "
               "writes it (3D BAG: 1.2, 1.3 or 2.2); a coarser one makes a simpler mesh. Default: each "
               "building's highest.",
        "FILL_UNDER_ROOFS": "Make every column solid from the ground up to its roof, as for airborne LiDAR: for "
                            "city models whose walls are missing (the air would get in and leave the blocks "
                            "hollow; the run warns of it). Passages and overhangs are filled too.",
        "VOXEL_SIZE": "Edge of a voxel in metres. Details smaller than about a voxel disappear; halving it "
                      "costs about 8 times the memory and time.",
        "MIN_HEIGHT": "Blocks lower than this (m, top above the ground under them) are dropped.",
        "MIN_FOOTPRINT": "Blocks covering less ground than this (m²) are dropped.",
        "MIN_VOLUME": "Blocks smaller than this (m³) are dropped.",
        "EXTENT": "The domain: data outside is ignored, and blocks crossing its edge are closed on it. "
                  "Default: the extent of the data. An extent in another CRS than the data's (drawn on a map, "
                  "or typed with its CRS, e.g. [EPSG:4326]) is transformed into the data's, as its bounding box.",
        "SMOOTHING_ITERATIONS": "Vertex-only Catmull-Clark passes over the voxel surfaces (the paper uses 3); "
                                "0 keeps the voxel faces.",
        "PROJECT": "Move the smoothed nodes onto moving-least-squares planes of the data, along their normals.",
        "QUALITY_THRESHOLD": "Smoothing and projection moves that would leave a face of lower quality "
                             "(inradius / longest edge, 1 for an equilateral triangle, 0.72 for a voxel face) "
                             "are refused.",
        "TILE_SIZE": "Cut the domain into square tiles of this side (m), each reconstructed on its own grid "
                     "with a halo around it, then merged: for areas whose grid does not fit in memory, or to "
                     "use several processes. A block crossing tiles is built whole by one tile; the result is "
                     "the same as with one grid. 0: one grid.",
        "WORKERS": "The number of worker processes for the tiles (a local Dask cluster); without a tile size, "
                   "tiles of 250 m. 0 or 1: the tiles run one after the other in QGIS's process. Needs the "
                   "Python package dask[distributed].",
        "SCHEDULER": "With tiles: the address of a running Dask scheduler (tcp://host:8786) whose workers have "
                     "urbanvox's core importable; overrides the worker count.",
        "MESH_BINARY": "Write the gmsh mesh file (.msh) in gmsh's binary encoding: the same content, read by "
                       "gmsh and meshio, written faster on a city, and with exact coordinates "
                       "(the text rounds them to 0.1 mm). The other mesh formats ignore it.",
        "OUTPUT_BLOCKS": "One feature per building block: its closed 3-D surface, with height, areas, volumes, "
                         "mesh quality and distance to the data.",
        "OUTPUT_FOOTPRINTS": "One polygon per building block: the ground it covers, with the same fields.",
        "OUTPUT_GROUND": "The terrain surface, in tiles of 64 x 64 voxels.",
        "OUTPUT_MESH": "Closed, conforming surfaces of every block, the ground and the air, for a finite-element "
                       "or CFD mesher: .msh (gmsh, physical groups), .vtu, .obj, .stl or .ply. "
                       "A PNG picture is written beside it.",
    }

    def helpLink(self):  # noqa: N802
        """A link to the README and to the method's paper figure, for the help panel."""
        picture = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(__file__))), "docs", "district.png")
        link = f'<p><a href="{self.helpUrl()}">README</a></p>'
        if os.path.exists(picture):
            link = f'<p><img src="{picture}" width="320"></p>' + link
        return link

    def helpUrl(self):  # noqa: N802 (QGIS API name)
        from qgis.PyQt.QtCore import QUrl

        readme = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(__file__))), "README.md")
        return QUrl.fromLocalFile(readme).toString() + "#use-in-qgis"

    def crsArgument(self, parameters, context):  # noqa: N802
        """The CRS parameter as the core wants it: an authority id, WKT, or None when not set."""
        crs = self.parameterAsCrs(parameters, self.CRS, context)
        if not crs.isValid():
            return None
        return crs.authid() or crs.toWkt()

    def inputCrs(self, parameters, context):  # noqa: N802
        """The CRS the input files name (pyproj), None if they name none (subclasses)."""
        return None

    def dataCrs(self, parameters, context):  # noqa: N802
        """The horizontal CRS of the data as the core takes it: the CRS parameter, else the one the
        input names (:meth:`inputCrs`); an invalid CRS when neither says (the core then stops)."""
        import pyproj

        from ...core.crs import horizontal_crs

        text = self.crsArgument(parameters, context)
        try:
            crs = pyproj.CRS.from_user_input(text) if text else self.inputCrs(parameters, context)
        except pyproj.exceptions.CRSError:
            crs = None  # the core says what is wrong with it
        if crs is None:
            return QgsCoordinateReferenceSystem()
        return QgsCoordinateReferenceSystem.fromWkt(horizontal_crs(crs).to_wkt())

    def extentArgument(self, parameters, context):  # noqa: N802
        """The EXTENT parameter as (xmin, ymin, xmax, ymax) in the data's CRS, or None.

        The extent may be in any CRS (drawn on a map, a layer's, typed with ``[EPSG:4326]``):
        it is transformed into the data's (:meth:`dataCrs`), its bounding box taken. An extent
        without a CRS is in the data's.
        """
        if not parameters.get(self.EXTENT):
            return None
        rect = self.parameterAsExtent(parameters, self.EXTENT, context)
        if rect.isNull() or rect.isEmpty():
            return None
        extent_crs = self.parameterAsExtentCrs(parameters, self.EXTENT, context)
        data_crs = self.dataCrs(parameters, context) if extent_crs.isValid() else QgsCoordinateReferenceSystem()
        if data_crs.isValid() and extent_crs != data_crs:
            try:
                rect = QgsCoordinateTransform(extent_crs, data_crs, context.transformContext()).transformBoundingBox(
                    rect)
            except QgsCsException as err:
                raise QgsProcessingException(self.tr(
                    "The domain extent cannot be transformed from {} into the data's CRS {}: {}").format(
                    extent_crs.userFriendlyIdentifier(), data_crs.userFriendlyIdentifier(), err)) from err
        return (float(rect.xMinimum()), float(rect.yMinimum()), float(rect.xMaximum()), float(rect.yMaximum()))

    def inputPath(self, parameters, name, context):  # noqa: N802
        """The file parameter ``name`` as a path, checked to exist ('' when an optional one is unset)."""
        path = self.parameterAsFile(parameters, name, context)
        return self.existingFile(path) if path else path

    def existingFile(self, path):  # noqa: N802
        """``path``, or an error saying it is a folder or is not found."""
        if os.path.isdir(path):
            raise QgsProcessingException(self.tr("{} is a folder: choose a file.").format(path))
        if not os.path.isfile(path):
            raise QgsProcessingException(self.tr("File not found: {}").format(path))
        return path

    def checkParameterValues(self, parameters, context):  # noqa: N802 (QGIS API name)
        """QGIS's checks, then the mesh file's name: its extension and folder are checked before
        the run, which is long, rather than by the core's writer once it is over."""
        ok, message = super().checkParameterValues(parameters, context)
        if not ok:
            return ok, message
        mesh_path = self.meshPath(parameters, context)
        problem = mesh_path_problem(mesh_path, self.tr) if mesh_path else None
        return (False, problem) if problem else (True, "")

    def meshPath(self, parameters, context):  # noqa: N802
        """OUTPUT_MESH as a path, '' when it is not asked for."""
        value = parameters.get(self.OUTPUT_MESH)
        if value is None or value == "":
            return ""
        return self.parameterAsFileOutput(parameters, self.OUTPUT_MESH, context) or ""

    # -- running ------------------------------------------------------------------------------

    def requiredModules(self, parameters, context):  # noqa: N802
        """Python modules this run needs (subclasses extend)."""
        return BASE_MODULES

    def reconstruct(self, pipeline, parameters, context, params, tiles, progress, is_cancelled):
        """Run the core for this algorithm's input and return its result (subclasses)."""
        raise NotImplementedError

    def tileOptions(self, parameters, context):  # noqa: N802
        """TILE_SIZE, WORKERS and SCHEDULER as core.tiles.TileOptions, or None for one grid.

        Workers or a scheduler without a tile size mean tiles of the core's default size:
        several processes need several tiles.
        """
        from ...core.tiles import TileOptions

        size = self.parameterAsDouble(parameters, self.TILE_SIZE, context) or 0.0
        workers = int(self.parameterAsInt(parameters, self.WORKERS, context) or 0)
        scheduler = (self.parameterAsString(parameters, self.SCHEDULER, context) or "").strip() or None
        if size <= 0 and workers <= 1 and not scheduler:
            return None
        if size <= 0:
            size = TileOptions.tile_size
        return TileOptions(tile_size=float(size), workers=workers, scheduler=scheduler)

    def schedulerError(self, scheduler, err):  # noqa: N802
        """The QgsProcessingException for a Dask scheduler that cannot be reached at ``scheduler``."""
        return QgsProcessingException(self.tr(
            "Could not connect to the Dask scheduler at {} ({}). Check that the scheduler is running and "
            "reachable at that address (tcp://host:port, by default port 8786), or leave the Dask scheduler "
            "address empty to run the tiles on local workers.").format(scheduler, err))

    def processAlgorithm(self, parameters, context, feedback):  # noqa: N802 (QGIS API name)
        missing = [m for m in self.requiredModules(parameters, context) if importlib.util.find_spec(m) is None]
        if missing:
            raise QgsProcessingException(missing_dependency_message(missing))
        mesh_path = self.meshPath(parameters, context)
        problem = mesh_path_problem(mesh_path, self.tr) if mesh_path else None
        if problem:  # a script's run.processAlgorithm() skips checkParameterValues
            raise QgsProcessingException(problem)
        from ...core import pipeline  # imported here: it needs the modules just checked
        from ...core.errors import UrbanvoxError
        from ...core.progress import translated

        params = pipeline.ReconstructionParams(
            voxel_size=self.parameterAsDouble(parameters, self.VOXEL_SIZE, context),
            min_height=self.parameterAsDouble(parameters, self.MIN_HEIGHT, context),
            min_footprint=self.parameterAsDouble(parameters, self.MIN_FOOTPRINT, context),
            min_volume=self.parameterAsDouble(parameters, self.MIN_VOLUME, context),
            smoothing_iterations=self.parameterAsInt(parameters, self.SMOOTHING_ITERATIONS, context),
            project=self.parameterAsBoolean(parameters, self.PROJECT, context),
            quality_threshold=self.parameterAsDouble(parameters, self.QUALITY_THRESHOLD, context),
            extent=self.extentArgument(parameters, context),
        )

        tiles = self.tileOptions(parameters, context)
        where = tiles and (tiles.scheduler or self.tr("{} worker(s)").format(max(1, tiles.workers)))
        tiled = []  # said once the core cuts the domain: data that fit in one tile never reach Dask

        def progress(fraction, message=None):
            feedback.setProgress(RECONSTRUCTION_PERCENT * min(max(float(fraction), 0.0), 1.0))
            if message:
                if tiles is not None and not tiled and _says(message, _TILING_MESSAGE):
                    tiled.append(True)
                    feedback.pushInfo(self.tr("Tiles of {} m on {}").format(tiles.tile_size, where))
                feedback.setProgressText(translated(message, self.tr))

        try:
            result = self.reconstruct(pipeline, parameters, context, params, tiles, progress,
                                      feedback.isCanceled)
        except UrbanvoxError as err:  # includes Cancelled
            raise QgsProcessingException(self.qgisWording(str(err))) from err
        except (OSError, ValueError) as err:
            # dask.distributed's Client: OSError when nothing answers (after its 30 s timeout),
            # ValueError for an address it cannot parse.
            if tiled and tiles.scheduler and (isinstance(err, OSError) or tiles.scheduler in str(err)):
                raise self.schedulerError(tiles.scheduler, err) from err
            raise
        if tiles is not None and not tiled:
            feedback.pushInfo(self.tr("The data fit in one tile of {} m: reconstructed in this process, "
                                      "without {}.").format(tiles.tile_size, where))

        for warning in result.warnings:
            feedback.pushWarning(self.qgisWording(translated(warning, self.tr)))
        if feedback.isCanceled():  # before the first output: nothing half-written
            raise QgsProcessingException(self.tr("Cancelled; no output was written."))
        return self.writeOutputs(result, parameters, context, feedback)

    def qgisWording(self, message):  # noqa: N802
        """``message`` (the core's, translated) as QGIS words it: a parameter named with the
        command line's flag, ``FILL_UNDER_ROOFS (--fill-under-roofs)``, by its label in the
        dialog and its name, ``"Fill every column up to its roof" (FILL_UNDER_ROOFS)``."""
        def label(match):
            definition = self.parameterDefinition(match.group(1))
            if definition is None:
                return match.group(0)
            return f'"{definition.description()}" ({match.group(1)})'

        return _FLAG_NAMED.sub(label, message)

def _says(message, text):
    """Whether the core's progress ``message`` is ``text``, or holds it as a part (a cluster's
    "Cluster 1/2: ..." made by core.progress.Text)."""
    if isinstance(message, str) and str.__eq__(message, text):
        return True
    return any(_says(part, text) for part in getattr(message, "parts", ()))
