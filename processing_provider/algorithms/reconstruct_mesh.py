"""``urbanvox:reconstructfrommesh``: building blocks from a triangle mesh (CityGML-derived STL, OBJ, PLY, OFF)
or a CityJSON city model."""

import json
import os

from qgis.core import QgsProcessingParameterBoolean, QgsProcessingParameterFile, QgsProcessingParameterString

from ..compat import FILE_BEHAVIOR, FLAG_ADVANCED
from .base import BASE_MODULES, UrbanvoxAlgorithm

MESH_FILTER = "Meshes and CityJSON (*.stl *.obj *.ply *.off *.json *.jsonl);;All files (*.*)"


class ReconstructFromMesh(UrbanvoxAlgorithm):
    GROUND = "GROUND"
    FILL_UNDER_ROOFS = "FILL_UNDER_ROOFS"
    LOD = "LOD"
    INPUT_TAGS = "cityjson,citygml,city model,lod2,stl,obj,ply,3d bag"
    INPUT_HELP = {
        "INPUT": "A building mesh (STL, OBJ, PLY or OFF, of any quality: overlaps, gaps, inner surfaces) or a "
                 "CityJSON file or sequence (.json, .jsonl), whose Building, BuildingPart and "
                 "BuildingInstallation surfaces are read.",
        "CRS": "Coordinate reference system of the coordinates, projected (metres or feet). Required for STL, "
               "OBJ, PLY and OFF, which carry none; a CityJSON file's referenceSystem is used when it is not set.",
    }

    def name(self):
        return "reconstructfrommesh"

    def displayName(self):  # noqa: N802 (QGIS API name)
        return self.tr("Reconstruct building blocks from mesh")

    def shortHelpString(self):  # noqa: N802 (QGIS API name)
        return self.tr(
            "<p>Voxel building blocks from a triangle mesh of buildings, e.g. an STL exported from CityGML "
            "(also OBJ, PLY, OFF), or from a CityJSON city model (.json), whose buildings' polygons are "
            "triangulated. Triangles may overlap, intersect or leave gaps: they are sampled into points "
            "no farther apart than 10% of a voxel.</p>"
            "<p><b>Ground mesh</b> [optional]: a mesh of the terrain, or a CityJSON file with a TINRelief; "
            "without it the ground is a CityJSON input's own terrain, if it has one, else it is taken under "
            "the lowest building points.<br>"
            "<b>CRS</b>: required for STL, OBJ, PLY and OFF, which carry none; a CityJSON file's "
            "referenceSystem is used when it is not set.<br>"
            "<b>Fill every column up to its roof</b> [advanced]: for models whose walls are missing, which "
            "the air fills (the run warns of hollow blocks).</p>"
        ) + self.tr(self.COMMON_HELP) + self.tr(
            "<p>From a CityJSON file, both layers also have the fields building_ids, the identifiers of the "
            "buildings each block holds, separated by ';' (a BuildingPart counts as its Building; a building "
            "is in every block that covers a quarter of its plan area or more), and n_buildings.</p>"
        ) + self.helpLink()

    def addInputParameters(self):  # noqa: N802
        self.addParameter(
            QgsProcessingParameterFile(
                self.INPUT, self.tr("Building mesh (STL/OBJ/PLY/OFF) or CityJSON"), behavior=FILE_BEHAVIOR,
                fileFilter=MESH_FILTER
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
        # Optional: a CityJSON file may name its own; a mesh without it stops with a message saying so.
        self.addCrsParameter("CRS of the coordinates (required for STL/OBJ/PLY/OFF)", optional=True)
        fill = QgsProcessingParameterBoolean(self.FILL_UNDER_ROOFS, self.tr("Fill every column up to its roof"),
                                             defaultValue=False)
        lod = QgsProcessingParameterString(self.LOD, self.tr("CityJSON level of detail (default: the highest)"),
                                           optional=True)
        for parameter in (lod, fill):
            parameter.setFlags(parameter.flags() | FLAG_ADVANCED)
            self.addParameter(parameter)

    def requiredModules(self, parameters, context):  # noqa: N802
        # The suffixes of core.readers.cityjson.is_cityjson, not the function: importing core.readers
        # imports laspy, one of the modules this check is for.
        files = [self.parameterAsFile(parameters, name, context) for name in (self.INPUT, self.GROUND)]
        if all(not path or path.lower().endswith((".json", ".jsonl")) for path in files):
            return BASE_MODULES  # CityJSON: read with json and shapely
        return BASE_MODULES + ("trimesh",)

    def inputCrs(self, parameters, context):  # noqa: N802
        """A CityJSON input's referenceSystem (pyproj), None for a mesh or a file that names none.

        Read only for an extent in another CRS than the data's; a CityJSON file (not a
        sequence, whose first line is its header) is parsed whole for it.
        """
        import pyproj

        path = self.parameterAsFile(parameters, self.INPUT, context)
        if not path.lower().endswith((".json", ".jsonl")) or not os.path.isfile(path):
            return None
        try:
            with open(path, "rb") as file:
                header = json.loads(file.readline()) if path.lower().endswith(".jsonl") else json.load(file)
            metadata = header.get("metadata") or {}
            text = metadata.get("referenceSystem") or metadata.get("crs")
            return pyproj.CRS.from_user_input(str(text)) if text else None
        except (OSError, ValueError, AttributeError, pyproj.exceptions.CRSError):
            return None  # the core's reading says what is wrong with the file

    def reconstruct(self, pipeline, parameters, context, params, tiles, progress, is_cancelled):
        return pipeline.reconstruct_mesh(
            self.inputPath(parameters, self.INPUT, context),
            ground_path=self.inputPath(parameters, self.GROUND, context) or None,
            crs=self.crsArgument(parameters, context),
            params=params,
            fill_under_roofs=self.parameterAsBoolean(parameters, self.FILL_UNDER_ROOFS, context),
            lod=self.parameterAsString(parameters, self.LOD, context).strip() or None,
            tiles=tiles,
            progress=progress,
            is_cancelled=is_cancelled,
        )
