"""urbanvox core: the smoothed-voxel method for urban finite-element geometry.

Pure Python (numpy, scipy, laspy, trimesh, pyproj, shapely); nothing here imports
``qgis``. Every module is one step of the paper, in pipeline order:

=====================  ====================================================  ========
module                 step                                                  paper
=====================  ====================================================  ========
``readers/las.py``     LAS/LAZ points with their class codes and CRS         §2
``readers/mesh.py``    STL/OBJ/PLY/OFF triangles                             §2
``sampling.py``        triangles -> points, spacing <= 10 % of a voxel       §2
``grid.py``            the voxel lattice, eq. (1)                            §2
``ground.py``          ground level of every grid column                     §2
``classify.py``        ground / building / air, flood fill of air            §2
``blocks.py``          6-connected blocks, thresholds, attributes            §3.1-3.2
``manifold.py``        well-composed labels: closed 2-manifold surfaces      §3.3
``surface.py``         conforming quads with the two regions they separate   §3.3
``eliminate.py``       unsupported boundary voxel elimination                §3.4
``smooth.py``          vertex-only Catmull-Clark smoothing                   §4.1
``project.py``         nodal normals, MLS projection onto the data           §4.2
``quality.py``         face quality, best quad split, move acceptance        §4
``intersect.py``       moves that would make faces cross are undone          §4.2
``measure.py``         per-block volume, areas, quality, distance to data
``export.py``          mesh files (.msh .vtu .obj .stl .ply)
``pipeline.py``        the steps in order, with progress and cancel
``reconstruction.py``  the result: layer rows and geometries, mesh files, preview
``clusters.py``        scattered data: one grid per cluster, merged
``tiles.py``           tiles with a halo, owned blocks, merged as one run
``workers.py``         where tiles run: this process or Dask workers
``cli.py``             ``python -m core``: the method from the command line
=====================  ====================================================  ========
"""
