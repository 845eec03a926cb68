"""``urbanvox:reconstructfrommesh``: building blocks from a triangle mesh (CityGML-derived STL, OBJ, PLY, OFF)."""

from qgis.core import QgsProcessingParameterFile

from ..compat import FILE_BEHAVIOR
from .base import BASE_MODULES, UrbanvoxAlgorithm

MESH_FILTER = "Meshes (*.stl *.obj *.ply *.off);;All files (*.*)"


class ReconstructFromMesh(UrbanvoxAlgorithm):
    GROUND = "GROUND"

    def name(self):
        return "reconstructfrommesh"

    def displayName(self):  # noqa: N802 (QGIS API name)
        return self.tr("Reconstruct building blocks from mesh")

    def shortHelpString(self):  # noqa: N802 (QGIS API name)
        return self.tr(
            "<p>Voxel building blocks from a triangle mesh of buildings, e.g. an STL exported from CityGML "
            "(also OBJ, PLY, OFF). Triangles may overlap, intersect or leave gaps: they are sampled into points "
            "no farther apart than 10% of a voxel.</p>"
            "<p><b>Ground mesh</b> [optional]: a mesh of the terrain; without it the ground is taken under the "
            "lowest building points.<br>"
            "<b>CRS</b>: required, since STL and most mesh formats carry none.</p>"
        ) + self.tr(self.COMMON_HELP) + self.helpLink()

    def addInputParameters(self):  # noqa: N802
        self.addParameter(
            QgsProcessingParameterFile(
                self.INPUT, self.tr("Building mesh (STL/OBJ/PLY/OFF)"), behavior=FILE_BEHAVIOR, fileFilter=MESH_FILTER
            )
        )
        self.addParameter(
            QgsProcessingParameterFile(
                self.GROUND,
                self.tr("Ground mesh"),
                behavior=FILE_BEHAVIOR,
                fileFilter=MESH_FILTER,
                optional=True,
            )
        )
        self.addCrsParameter("CRS of the mesh coordinates", optional=False)

    def requiredModules(self, parameters, context):  # noqa: N802
        return BASE_MODULES + ("trimesh",)

    def reconstruct(self, pipeline, parameters, context, params, tiles, progress, is_cancelled):
        return pipeline.reconstruct_mesh(
            self.inputPath(parameters, self.INPUT, context),
            ground_path=self.inputPath(parameters, self.GROUND, context) or None,
            crs=self.crsArgument(parameters, context),
            params=params,
            tiles=tiles,
            progress=progress,
            is_cancelled=is_cancelled,
        )
