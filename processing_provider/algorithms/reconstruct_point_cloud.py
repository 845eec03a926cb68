"""``urbanvox:reconstructfrompointcloud``: building blocks from a classified LAS/LAZ point cloud."""

import os

from qgis.core import QgsProcessingException, QgsProcessingParameterMultipleLayers, QgsProcessingParameterString

from ..compat import SOURCE_FILE
from .base import BASE_MODULES, UrbanvoxAlgorithm

#: The point cloud files read, also those of a folder given as INPUT.
LAS_SUFFIXES = (".las", ".laz")


class ReconstructFromPointCloud(UrbanvoxAlgorithm):
    GROUND_CLASSES = "GROUND_CLASSES"
    BUILDING_CLASSES = "BUILDING_CLASSES"
    INPUT_TAGS = "lidar,las,laz,point cloud,classification,ahn,lidar hd"
    INPUT_HELP = {
        "INPUT": "One or several classified LAS/LAZ files (a tile collection, or a folder of them, is read as "
                 "one cloud); the ground and building classes are chosen below.",
        "CRS": "Coordinate reference system of the points, projected (metres or feet). Default: the one in the "
               "file header; required when the header has none (AHN3: EPSG:28992).",
    }

    def name(self):
        return "reconstructfrompointcloud"

    def displayName(self):  # noqa: N802 (QGIS API name)
        return self.tr("Reconstruct building blocks from point cloud")

    def shortHelpString(self):  # noqa: N802 (QGIS API name)
        return self.tr(
            "<p>Voxel building blocks from a classified LiDAR point cloud: one or several .las/.laz files "
            "(a tile collection, as LiDAR is delivered, is read as one cloud).</p>"
            "<p><b>CRS</b>: the coordinate reference system of the points; by default the one in the file "
            "header. Required when the header has none (e.g. AHN3 tiles: EPSG:28992); it overrides the header.<br>"
            "<b>Ground classes</b> / <b>Building classes</b>: ASPRS classification codes, comma-separated "
            "(ground 2, building 6 in standard LAS). Points of other classes are ignored.</p>"
        ) + self.tr(self.COMMON_HELP) + self.helpLink()

    def addInputParameters(self):  # noqa: N802
        self.addParameter(
            QgsProcessingParameterMultipleLayers(self.INPUT, self.tr("Point cloud files (LAS/LAZ)"), SOURCE_FILE)
        )
        self.addCrsParameter("CRS of the points (default: from the file header)", optional=True)
        self.addParameter(
            QgsProcessingParameterString(self.GROUND_CLASSES, self.tr("Ground classes (comma-separated)"), "2")
        )
        self.addParameter(
            QgsProcessingParameterString(self.BUILDING_CLASSES, self.tr("Building classes (comma-separated)"), "6")
        )

    def inputPaths(self, parameters, context):  # noqa: N802
        """The INPUT files, checked to exist and to be LAS/LAZ; a folder gives the LAS/LAZ files in it."""
        given = [str(p) for p in self.parameterAsFileList(parameters, self.INPUT, context)]
        if not given:
            raise QgsProcessingException(self.tr("No point cloud file given (INPUT)."))
        paths = []
        for path in given:
            if os.path.isdir(path):
                paths += self.folderFiles(path)
                continue
            if not os.path.exists(path) and ";" in path:
                # A list written as one string, as a batch or a model may give it
                paths += [self.existingFile(p.strip()) for p in path.split(";") if p.strip()]
                continue
            paths.append(self.existingFile(path))
        for path in paths:
            if not path.lower().endswith(LAS_SUFFIXES):
                raise QgsProcessingException(self.tr("Not a LAS/LAZ file: {}").format(path))
        return paths

    def folderFiles(self, folder):  # noqa: N802
        """The LAS/LAZ files in ``folder`` (not its subfolders), in name order; an error if it has none."""
        files = sorted(os.path.join(folder, name) for name in os.listdir(folder)
                       if name.lower().endswith(LAS_SUFFIXES) and os.path.isfile(os.path.join(folder, name)))
        if not files:
            raise QgsProcessingException(self.tr("The folder {} holds no LAS/LAZ file (.las, .laz).").format(folder))
        return files

    def existingFile(self, path):  # noqa: N802
        """``path``, or an error saying it is not found (a file or a folder of them)."""
        if not os.path.exists(path):
            raise QgsProcessingException(self.tr("File or folder not found: {}").format(path))
        return super().existingFile(path)

    def inputCrs(self, parameters, context):  # noqa: N802
        """The first CRS the LAS/LAZ headers declare (pyproj), None if none does."""
        import laspy

        for path in self.inputPaths(parameters, context):
            try:
                with laspy.open(path) as reader:
                    crs = reader.header.parse_crs()
            except Exception:  # noqa: BLE001 (an unreadable file: the core's reading says what is wrong)
                continue
            if crs is not None:
                return crs
        return None

    def requiredModules(self, parameters, context):  # noqa: N802
        modules = BASE_MODULES + ("laspy",)
        files = []
        for path in (str(p) for p in self.parameterAsFileList(parameters, self.INPUT, context)):
            files += os.listdir(path) if os.path.isdir(path) else [path]
        if any(p.lower().endswith(".laz") for p in files):
            modules += ("lazrs",)
        return modules

    def reconstruct(self, pipeline, parameters, context, params, tiles, progress, is_cancelled):
        return pipeline.reconstruct_point_cloud(
            self.inputPaths(parameters, context),
            crs=self.crsArgument(parameters, context),
            ground_classes=self.parameterAsString(parameters, self.GROUND_CLASSES, context),
            building_classes=self.parameterAsString(parameters, self.BUILDING_CLASSES, context),
            params=params,
            tiles=tiles,
            progress=progress,
            is_cancelled=is_cancelled,
        )
