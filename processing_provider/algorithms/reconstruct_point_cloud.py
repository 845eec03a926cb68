"""``urbanvox:reconstructfrompointcloud``: building blocks from a classified LAS/LAZ point cloud."""

from qgis.core import QgsProcessingException, QgsProcessingParameterMultipleLayers, QgsProcessingParameterString

from ..compat import SOURCE_FILE
from .base import BASE_MODULES, UrbanvoxAlgorithm


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
        """The INPUT files, checked to exist and to be LAS/LAZ."""
        paths = [str(p) for p in self.parameterAsFileList(parameters, self.INPUT, context)]
        if not paths:
            raise QgsProcessingException(self.tr("No point cloud file given (INPUT)."))
        for path in paths:
            self.existingFile(path)
            if not path.lower().endswith((".las", ".laz")):
                raise QgsProcessingException(self.tr("Not a LAS/LAZ file: {}").format(path))
        return paths

    def requiredModules(self, parameters, context):  # noqa: N802
        modules = BASE_MODULES + ("laspy",)
        files = [str(p) for p in self.parameterAsFileList(parameters, self.INPUT, context)]
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
