"""``urbanvox:reconstructfrompointcloud``: building blocks from a classified LAS/LAZ point cloud."""

from qgis.core import QgsProcessingParameterFile, QgsProcessingParameterString

from ..compat import FILE_BEHAVIOR
from .base import BASE_MODULES, UrbanvoxAlgorithm


class ReconstructFromPointCloud(UrbanvoxAlgorithm):
    GROUND_CLASSES = "GROUND_CLASSES"
    BUILDING_CLASSES = "BUILDING_CLASSES"

    def name(self):
        return "reconstructfrompointcloud"

    def displayName(self):  # noqa: N802 (QGIS API name)
        return self.tr("Reconstruct building blocks from point cloud")

    def shortHelpString(self):  # noqa: N802 (QGIS API name)
        return self.tr(
            "<p>Voxel building blocks from a classified LiDAR point cloud (.las or .laz).</p>"
            "<p><b>CRS</b>: the coordinate reference system of the points; by default the one in the file "
            "header. Required when the header has none (e.g. AHN3 tiles: EPSG:28992); it overrides the header.<br>"
            "<b>Ground classes</b> / <b>Building classes</b>: ASPRS classification codes, comma-separated "
            "(ground 2, building 6 in standard LAS). Points of other classes are ignored.</p>"
        ) + self.tr(self.COMMON_HELP) + self.helpLink()

    def addInputParameters(self):  # noqa: N802
        self.addParameter(
            QgsProcessingParameterFile(
                self.INPUT, self.tr("Point cloud (LAS/LAZ)"), behavior=FILE_BEHAVIOR, fileFilter="LAS/LAZ (*.las *.laz)"
            )
        )
        self.addCrsParameter("CRS of the points (default: from the file header)", optional=True)
        self.addParameter(
            QgsProcessingParameterString(self.GROUND_CLASSES, self.tr("Ground classes (comma-separated)"), "2")
        )
        self.addParameter(
            QgsProcessingParameterString(self.BUILDING_CLASSES, self.tr("Building classes (comma-separated)"), "6")
        )

    def requiredModules(self, parameters, context):  # noqa: N802
        modules = BASE_MODULES + ("laspy",)
        if self.parameterAsFile(parameters, self.INPUT, context).lower().endswith(".laz"):
            modules += ("lazrs",)
        return modules

    def reconstruct(self, pipeline, parameters, context, params, progress, is_cancelled):
        return pipeline.reconstruct_point_cloud(
            self.inputPath(parameters, self.INPUT, context),
            crs=self.crsArgument(parameters, context),
            ground_classes=self.parameterAsString(parameters, self.GROUND_CLASSES, context),
            building_classes=self.parameterAsString(parameters, self.BUILDING_CLASSES, context),
            params=params,
            progress=progress,
            is_cancelled=is_cancelled,
        )
