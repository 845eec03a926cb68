<?xml version="1.0" encoding="utf-8"?>
<!DOCTYPE TS>
<TS version="2.1" language="fr">
  <context>
    <name>urbanvox</name>
    <message>
      <source>urbanvox: voxel building blocks from point clouds and meshes</source>
      <translation>urbanvox : îlots bâtis voxelisés à partir de nuages de points et de maillages</translation>
    </message>
    <message>
      <source>Point cloud files (LAS/LAZ)</source>
      <translation>Fichiers de nuage de points (LAS/LAZ)</translation>
    </message>
    <message>
      <source>CRS of the points (default: from the file header)</source>
      <translation>SCR des points (par défaut : celui de l'en-tête du fichier)</translation>
    </message>
    <message>
      <source>Ground classes (comma-separated)</source>
      <translation>Classes du sol (séparées par des virgules)</translation>
    </message>
    <message>
      <source>Building classes (comma-separated)</source>
      <translation>Classes des bâtiments (séparées par des virgules)</translation>
    </message>
    <message>
      <source>Voxel size (m)</source>
      <translation>Taille des voxels (m)</translation>
    </message>
    <message>
      <source>Minimum block height (m)</source>
      <translation>Hauteur minimale d'un îlot (m)</translation>
    </message>
    <message>
      <source>Minimum block footprint (m²)</source>
      <translation>Emprise minimale d'un îlot (m²)</translation>
    </message>
    <message>
      <source>Minimum block volume (m³)</source>
      <translation>Volume minimal d'un îlot (m³)</translation>
    </message>
    <message>
      <source>Domain extent (default: the data's)</source>
      <translation>Emprise du domaine (par défaut : celle des données)</translation>
    </message>
    <message>
      <source>Smoothing passes (Catmull-Clark)</source>
      <translation>Passes de lissage (Catmull-Clark)</translation>
    </message>
    <message>
      <source>Project the smoothed surfaces onto the data</source>
      <translation>Projeter les surfaces lissées sur les données</translation>
    </message>
    <message>
      <source>Minimum face quality (inradius / longest edge, 1 = equilateral)</source>
      <translation>Qualité minimale des faces (rayon inscrit / plus grand côté, 1 = équilatéral)</translation>
    </message>
    <message>
      <source>Tile size (m, 0 = one grid)</source>
      <translation>Taille des tuiles (m, 0 = une seule grille)</translation>
    </message>
    <message>
      <source>Worker processes for the tiles (Dask)</source>
      <translation>Processus de calcul pour les tuiles (Dask)</translation>
    </message>
    <message>
      <source>Dask scheduler address (default: local workers)</source>
      <translation>Adresse d'un ordonnanceur Dask (par défaut : processus locaux)</translation>
    </message>
    <message>
      <source>Write a .msh mesh file in binary</source>
      <translation>Écrire le maillage .msh en binaire</translation>
    </message>
    <message>
      <source>Building blocks (3D surfaces)</source>
      <translation>Îlots bâtis (surfaces 3D)</translation>
    </message>
    <message>
      <source>Building footprints</source>
      <translation>Emprises des îlots bâtis</translation>
    </message>
    <message>
      <source>Ground surface</source>
      <translation>Surface du sol</translation>
    </message>
    <message>
      <source>Conforming mesh file (blocks, ground, air)</source>
      <translation>Fichier de maillage conforme (îlots, sol, air)</translation>
    </message>
    <message>
      <source>gmsh (*.msh);;VTK unstructured grid (*.vtu);;Wavefront OBJ (*.obj);;STL, one solid per region (*.stl);;PLY (*.ply)</source>
      <translation>gmsh (*.msh);;Maillage non structuré VTK (*.vtu);;Wavefront OBJ (*.obj);;STL, un solide par région (*.stl);;PLY (*.ply)</translation>
    </message>
    <message>
      <source>Preview picture (PNG)</source>
      <translation>Image d'aperçu (PNG)</translation>
    </message>
    <message>
      <source>Number of building blocks</source>
      <translation>Nombre d'îlots bâtis</translation>
    </message>
    <message>
      <source>Total volume of the blocks (m³)</source>
      <translation>Volume total des îlots (m³)</translation>
    </message>
    <message>
      <source>ASPRS classification codes of the ground points, comma-separated (standard: 2).</source>
      <translation>Codes de classification ASPRS des points du sol, séparés par des virgules (standard : 2).</translation>
    </message>
    <message>
      <source>Classification codes of the building points, comma-separated (standard: 6); vegetation, noise and other codes are ignored.</source>
      <translation>Codes de classification des points de bâtiment, séparés par des virgules (standard : 6) ; la végétation, le bruit et les autres codes sont ignorés.</translation>
    </message>
    <message>
      <source>Edge of a voxel in metres. Details smaller than about a voxel disappear; halving it costs about 8 times the memory and time.</source>
      <translation>Arête d'un voxel en mètres. Les détails plus petits qu'environ un voxel disparaissent ; la diviser par deux coûte environ 8 fois plus de mémoire et de temps.</translation>
    </message>
    <message>
      <source>Blocks lower than this (m, top above the ground under them) are dropped.</source>
      <translation>Les îlots plus bas que cela (m, sommet au-dessus du sol sous l'îlot) sont supprimés.</translation>
    </message>
    <message>
      <source>Blocks covering less ground than this (m²) are dropped.</source>
      <translation>Les îlots couvrant moins de sol que cela (m²) sont supprimés.</translation>
    </message>
    <message>
      <source>Blocks smaller than this (m³) are dropped.</source>
      <translation>Les îlots plus petits que cela (m³) sont supprimés.</translation>
    </message>
    <message>
      <source>The domain: data outside is ignored, and blocks crossing its edge are closed on it. Default: the extent of the data. An extent in another CRS than the data's (drawn on a map, or typed with its CRS, e.g. [EPSG:4326]) is transformed into the data's, as its bounding box.</source>
      <translation>Le domaine : les données en dehors sont ignorées et les îlots qui en franchissent le bord y sont fermés. Par défaut : l'emprise des données. Une emprise dans un autre SCR que celui des données (tracée sur une carte, ou saisie avec son SCR, p. ex. [EPSG:4326]) est transformée dans celui des données, en son rectangle englobant.</translation>
    </message>
    <message>
      <source>Vertex-only Catmull-Clark passes over the voxel surfaces (the paper uses 3); 0 keeps the voxel faces.</source>
      <translation>Passes de Catmull-Clark (sommets seulement) sur les surfaces voxelisées (l'article en utilise 3) ; 0 conserve les faces des voxels.</translation>
    </message>
    <message>
      <source>Move the smoothed nodes onto moving-least-squares planes of the data, along their normals.</source>
      <translation>Déplacer les nœuds lissés sur des plans des moindres carrés mobiles des données, le long de leurs normales.</translation>
    </message>
    <message>
      <source>Smoothing and projection moves that would leave a face of lower quality (inradius / longest edge, 1 for an equilateral triangle, 0.72 for a voxel face) are refused.</source>
      <translation>Les déplacements de lissage et de projection qui laisseraient une face de moindre qualité (rayon inscrit / plus grand côté, 1 pour un triangle équilatéral, 0,72 pour une face de voxel) sont refusés.</translation>
    </message>
    <message>
      <source>Cut the domain into square tiles of this side (m), each reconstructed on its own grid with a halo around it, then merged: for areas whose grid does not fit in memory, or to use several processes. A block crossing tiles is built whole by one tile; the result is the same as with one grid. 0: one grid.</source>
      <translation>Découpe le domaine en tuiles carrées de ce côté (m), chacune reconstruite sur sa propre grille avec une marge autour, puis fusionnées : pour les zones dont la grille ne tient pas en mémoire, ou pour utiliser plusieurs processus. Un îlot à cheval sur plusieurs tuiles est construit en entier par une seule ; le résultat est celui d'une seule grille. 0 : une seule grille.</translation>
    </message>
    <message>
      <source>The number of worker processes for the tiles (a local Dask cluster); without a tile size, tiles of 250 m. 0 or 1: the tiles run one after the other in QGIS's process. Needs the Python package dask[distributed].</source>
      <translation>Le nombre de processus de calcul pour les tuiles (un cluster Dask local) ; sans taille de tuile, des tuiles de 250 m. 0 ou 1 : les tuiles sont calculées l'une après l'autre dans le processus de QGIS. Nécessite le paquet Python dask[distributed].</translation>
    </message>
    <message>
      <source>With tiles: the address of a running Dask scheduler (tcp://host:8786) whose workers have urbanvox's core importable; overrides the worker count.</source>
      <translation>Avec des tuiles : l'adresse d'un ordonnanceur Dask en service (tcp://hôte:8786) dont les processus peuvent importer le cœur d'urbanvox ; remplace le nombre de processus.</translation>
    </message>
    <message>
      <source>Write the gmsh mesh file (.msh) in gmsh's binary encoding: the same content, read by gmsh and meshio, written faster on a city, and with exact coordinates (the text rounds them to 0.1 mm). The other mesh formats ignore it.</source>
      <translation>Écrit le fichier de maillage gmsh (.msh) dans l'encodage binaire de gmsh : le même contenu, lu par gmsh et meshio, écrit plus vite sur une ville, avec les coordonnées exactes (le texte les arrondit à 0,1 mm). Les autres formats de maillage l'ignorent.</translation>
    </message>
    <message>
      <source>One feature per building block: its closed 3-D surface, with height, areas, volumes, mesh quality and distance to the data.</source>
      <translation>Une entité par îlot bâti : sa surface 3D fermée, avec hauteur, aires, volumes, qualité du maillage et distance aux données.</translation>
    </message>
    <message>
      <source>One polygon per building block: the ground it covers, with the same fields.</source>
      <translation>Un polygone par îlot bâti : le sol qu'il couvre, avec les mêmes champs.</translation>
    </message>
    <message>
      <source>The terrain surface, in tiles of 64 x 64 voxels.</source>
      <translation>La surface du terrain, par tuiles de 64 x 64 voxels.</translation>
    </message>
    <message>
      <source>Closed, conforming surfaces of every block, the ground and the air, for a finite-element or CFD mesher: .msh (gmsh, physical groups), .vtu, .obj, .stl or .ply. A PNG picture is written beside it.</source>
      <translation>Surfaces fermées et conformes de chaque îlot, du sol et de l'air, pour un mailleur éléments finis ou CFD : .msh (gmsh, groupes physiques), .vtu, .obj, .stl ou .ply. Une image PNG est écrite à côté.</translation>
    </message>
    <message>
      <source>One or several classified LAS/LAZ files (a tile collection, or a folder of them, is read as one cloud); the ground and building classes are chosen below.</source>
      <translation>Un ou plusieurs fichiers LAS/LAZ classifiés (une collection de dalles, ou un dossier qui en contient, est lue comme un seul nuage) ; les classes du sol et des bâtiments se choisissent plus bas.</translation>
    </message>
    <message>
      <source>Coordinate reference system of the points, projected (metres or feet). Default: the one in the file header; required when the header has none (AHN3: EPSG:28992).</source>
      <translation>Système de coordonnées de référence des points, projeté (mètres ou pieds). Par défaut : celui de l'en-tête du fichier ; obligatoire quand l'en-tête n'en a pas (AHN3 : EPSG:28992).</translation>
    </message>
    <message>
      <source>Building mesh (STL/OBJ/PLY/OFF) or CityJSON</source>
      <translation>Maillage des bâtiments (STL/OBJ/PLY/OFF) ou CityJSON</translation>
    </message>
    <message>
      <source>Ground mesh</source>
      <translation>Maillage du sol</translation>
    </message>
    <message>
      <source>CRS of the coordinates (required for STL/OBJ/PLY/OFF)</source>
      <translation>SCR des coordonnées (obligatoire pour STL/OBJ/PLY/OFF)</translation>
    </message>
    <message>
      <source>Fill every column up to its roof</source>
      <translation>Remplir chaque colonne jusqu'à son toit</translation>
    </message>
    <message>
      <source>CityJSON level of detail (default: the highest)</source>
      <translation>Niveau de détail CityJSON (par défaut : le plus élevé)</translation>
    </message>
    <message>
      <source>Optional terrain mesh, or a CityJSON file's terrain (TINRelief); without it the ground is a CityJSON input's own terrain, else it passes through the bottom of every building part.</source>
      <translation>Maillage du terrain, ou terrain (TINRelief) d'un fichier CityJSON, facultatif ; sans lui, le sol est le terrain de l'entrée CityJSON, sinon il passe par le bas de chaque partie de bâtiment.</translation>
    </message>
    <message>
      <source>The level of detail a CityJSON file's buildings are taken at where they have it, as the file writes it (3D BAG: 1.2, 1.3 or 2.2); a coarser one makes a simpler mesh. Default: each building's highest.</source>
      <translation>Le niveau de détail auquel les bâtiments d'un fichier CityJSON sont pris quand ils l'ont, écrit comme dans le fichier (3D BAG : 1.2, 1.3 ou 2.2) ; un niveau plus grossier donne un maillage plus simple. Par défaut : le plus élevé de chaque bâtiment.</translation>
    </message>
    <message>
      <source>Make every column solid from the ground up to its roof, as for airborne LiDAR: for city models whose walls are missing (the air would get in and leave the blocks hollow; the run warns of it). Passages and overhangs are filled too.</source>
      <translation>Rendre chaque colonne pleine du sol jusqu'à son toit, comme pour le LiDAR aéroporté : pour les maquettes urbaines dont des murs manquent (l'air entrerait et laisserait les îlots creux ; le calcul le signale). Les passages et les porte-à-faux sont remplis aussi.</translation>
    </message>
    <message>
      <source>A building mesh (STL, OBJ, PLY or OFF, of any quality: overlaps, gaps, inner surfaces) or a CityJSON file or sequence (.json, .jsonl), whose Building, BuildingPart and BuildingInstallation surfaces are read.</source>
      <translation>Un maillage de bâtiments (STL, OBJ, PLY ou OFF, de toute qualité : chevauchements, trous, surfaces intérieures) ou un fichier ou une séquence CityJSON (.json, .jsonl), dont les surfaces des Building, BuildingPart et BuildingInstallation sont lues.</translation>
    </message>
    <message>
      <source>Coordinate reference system of the coordinates, projected (metres or feet). Required for STL, OBJ, PLY and OFF, which carry none; a CityJSON file's referenceSystem is used when it is not set.</source>
      <translation>Système de coordonnées de référence des coordonnées, projeté (mètres ou pieds). Obligatoire pour STL, OBJ, PLY et OFF, qui n'en portent pas ; le referenceSystem d'un fichier CityJSON est utilisé s'il n'est pas donné.</translation>
    </message>
    <message>
      <source>Reconstruct building blocks from mesh</source>
      <translation>Reconstruire les îlots bâtis à partir d'un maillage</translation>
    </message>
    <message>
      <source>&lt;p&gt;Voxel building blocks from a triangle mesh of buildings, e.g. an STL exported from CityGML (also OBJ, PLY, OFF), or from a CityJSON city model (.json), whose buildings' polygons are triangulated. Triangles may overlap, intersect or leave gaps: they are sampled into points no farther apart than 10% of a voxel.&lt;/p&gt;&lt;p&gt;&lt;b&gt;Ground mesh&lt;/b&gt; [optional]: a mesh of the terrain, or a CityJSON file with a TINRelief; without it the ground is a CityJSON input's own terrain, if it has one, else it is taken under the lowest building points.&lt;br&gt;&lt;b&gt;CRS&lt;/b&gt;: required for STL, OBJ, PLY and OFF, which carry none; a CityJSON file's referenceSystem is used when it is not set.&lt;br&gt;&lt;b&gt;Fill every column up to its roof&lt;/b&gt; [advanced]: for models whose walls are missing, which the air fills (the run warns of hollow blocks).&lt;/p&gt;</source>
      <translation>&lt;p&gt;Îlots bâtis voxelisés à partir d'un maillage triangulaire de bâtiments, par exemple un STL exporté de CityGML (aussi OBJ, PLY, OFF), ou d'une maquette urbaine CityJSON (.json), dont les polygones des bâtiments sont triangulés. Les triangles peuvent se chevaucher, se couper ou laisser des trous : ils sont échantillonnés en points espacés d'au plus 10 % d'un voxel.&lt;/p&gt;&lt;p&gt;&lt;b&gt;Maillage du sol&lt;/b&gt; [facultatif] : un maillage du terrain, ou un fichier CityJSON avec un TINRelief ; sans lui, le sol est le terrain de l'entrée CityJSON si elle en a un, sinon il est pris sous les points les plus bas des bâtiments.&lt;br&gt;&lt;b&gt;SCR&lt;/b&gt; : obligatoire pour STL, OBJ, PLY et OFF, qui n'en portent pas ; le referenceSystem d'un fichier CityJSON est utilisé s'il n'est pas donné.&lt;br&gt;&lt;b&gt;Remplir chaque colonne jusqu'à son toit&lt;/b&gt; [avancé] : pour les maquettes dont des murs manquent, que l'air remplit (le calcul signale les îlots creux).&lt;/p&gt;</translation>
    </message>
    <message>
      <source>&lt;p&gt;The data are put in a grid of cubic voxels; voxels are sorted into ground, building and air (air is flood-filled from above, so closed courtyards and inner surfaces are handled); face-connected building voxels form a building block. Blocks lower, smaller or lighter than the thresholds are dropped.&lt;/p&gt;&lt;p&gt;&lt;b&gt;Voxel size&lt;/b&gt;: edge of a voxel in metres; halving it multiplies memory and time by ~8.&lt;br&gt;&lt;b&gt;Minimum height / footprint / volume&lt;/b&gt;: blocks below any of them are discarded.&lt;br&gt;&lt;b&gt;Smoothing passes&lt;/b&gt;: vertex-only Catmull-Clark passes (paper: 3); nodes at the foot of the walls keep their height. &lt;b&gt;Project&lt;/b&gt;: move the smoothed nodes onto moving-least-squares planes of the data. &lt;b&gt;Minimum face quality&lt;/b&gt;: a smoothing or projection move that would leave a worse face is refused (a voxel face scores 0.72).&lt;br&gt;&lt;b&gt;Domain extent&lt;/b&gt;: clip the data; blocks crossing it are closed on its sides.&lt;/p&gt;&lt;p&gt;&lt;b&gt;Blocks&lt;/b&gt;: one MultiPolygonZ per block, its closed outer surface (smoothed and projected). &lt;b&gt;Footprints&lt;/b&gt;: one polygon per block (the columns it covers). Both have the fields block_id, height, ground_z, top_z, footprint_area (m²), volume (m³), surface_area (m²) and n_voxels of the voxel model, then mesh_volume, mesh_area, roof_area, facade_area, min_quality, mean_quality, mean_dist and max_dist (m, nodes to the data) of the final mesh. &lt;b&gt;Ground surface&lt;/b&gt;: the terrain, in tiles. &lt;b&gt;Mesh file&lt;/b&gt;: closed, conforming surfaces of every block, the ground and the air; the extension picks the format (.msh with physical groups per interface and per region, .vtu, .obj, .stl, .ply); a PNG preview is written beside it.&lt;/p&gt;</source>
      <translation>&lt;p&gt;Les données sont placées dans une grille de voxels cubiques ; les voxels sont classés en sol, bâtiment et air (l'air est propagé depuis le haut, ce qui traite les cours fermées et les surfaces intérieures) ; les voxels de bâtiment reliés par une face forment un îlot. Les îlots plus bas, plus petits ou plus légers que les seuils sont supprimés.&lt;/p&gt;&lt;p&gt;&lt;b&gt;Taille des voxels&lt;/b&gt; : arête d'un voxel en mètres ; la diviser par deux multiplie mémoire et temps par ~8.&lt;br&gt;&lt;b&gt;Hauteur / emprise / volume minimaux&lt;/b&gt; : les îlots en dessous de l'un d'eux sont écartés.&lt;br&gt;&lt;b&gt;Passes de lissage&lt;/b&gt; : passes de Catmull-Clark sur les sommets seulement (article : 3) ; les nœuds au pied des murs gardent leur altitude. &lt;b&gt;Projeter&lt;/b&gt; : déplacer les nœuds lissés sur des plans des moindres carrés mobiles des données. &lt;b&gt;Qualité minimale des faces&lt;/b&gt; : un déplacement qui laisserait une face moins bonne est refusé (une face de voxel vaut 0,72).&lt;br&gt;&lt;b&gt;Emprise du domaine&lt;/b&gt; : découpe les données ; les îlots qui la franchissent sont fermés sur ses côtés.&lt;/p&gt;&lt;p&gt;&lt;b&gt;Îlots&lt;/b&gt; : un MultiPolygonZ par îlot, sa surface extérieure fermée (lissée et projetée). &lt;b&gt;Emprises&lt;/b&gt; : un polygone par îlot (les colonnes qu'il couvre). Les deux ont les champs block_id, height, ground_z, top_z, footprint_area (m²), volume (m³), surface_area (m²) et n_voxels du modèle voxel, puis mesh_volume, mesh_area, roof_area, facade_area, min_quality, mean_quality, mean_dist et max_dist (m, des nœuds aux données) du maillage final. &lt;b&gt;Surface du sol&lt;/b&gt; : le terrain, par tuiles. &lt;b&gt;Fichier de maillage&lt;/b&gt; : surfaces fermées et conformes de chaque îlot, du sol et de l'air ; l'extension choisit le format (.msh avec groupes physiques par interface et par région, .vtu, .obj, .stl, .ply) ; un aperçu PNG est écrit à côté.&lt;/p&gt;</translation>
    </message>
    <message>
      <source>&lt;p&gt;From a CityJSON file, both layers also have the fields building_ids, the identifiers of the buildings each block holds, separated by ';' (a BuildingPart counts as its Building; a building is in every block that covers a quarter of its plan area or more), and n_buildings.&lt;/p&gt;</source>
      <translation>&lt;p&gt;Depuis un fichier CityJSON, les deux couches ont aussi les champs building_ids, les identifiants des bâtiments que contient chaque îlot, séparés par « ; » (une BuildingPart compte pour son Building ; un bâtiment est dans chaque îlot qui couvre au moins le quart de sa surface en plan), et n_buildings.&lt;/p&gt;</translation>
    </message>
    <message>
      <source>voxel,building,block,urban,city,3d,finite element,cfd,mesh,gmsh,catmull-clark</source>
      <translation>voxel,bâtiment,îlot,urbain,ville,3d,éléments finis,cfd,maillage,gmsh,catmull-clark</translation>
    </message>
    <message>
      <source>cityjson,citygml,city model,lod2,stl,obj,ply,3d bag</source>
      <translation>cityjson,citygml,maquette urbaine,lod2,stl,obj,ply,3d bag</translation>
    </message>
    <message>
      <source>Reconstruct building blocks from point cloud</source>
      <translation>Reconstruire les îlots bâtis à partir d'un nuage de points</translation>
    </message>
    <message>
      <source>&lt;p&gt;Voxel building blocks from a classified LiDAR point cloud: one or several .las/.laz files (a tile collection, as LiDAR is delivered, is read as one cloud).&lt;/p&gt;&lt;p&gt;&lt;b&gt;CRS&lt;/b&gt;: the coordinate reference system of the points; by default the one in the file header. Required when the header has none (e.g. AHN3 tiles: EPSG:28992); it overrides the header.&lt;br&gt;&lt;b&gt;Ground classes&lt;/b&gt; / &lt;b&gt;Building classes&lt;/b&gt;: ASPRS classification codes, comma-separated (ground 2, building 6 in standard LAS). Points of other classes are ignored.&lt;/p&gt;</source>
      <translation>&lt;p&gt;Îlots bâtis voxelisés à partir d'un nuage de points LiDAR classifié : un ou plusieurs fichiers .las/.laz (une collection de dalles, telle que le LiDAR est livré, est lue comme un seul nuage).&lt;/p&gt;&lt;p&gt;&lt;b&gt;SCR&lt;/b&gt; : le système de coordonnées des points ; par défaut celui de l'en-tête du fichier. Obligatoire quand l'en-tête n'en a pas (par ex. dalles AHN3 : EPSG:28992) ; il remplace celui de l'en-tête.&lt;br&gt;&lt;b&gt;Classes du sol&lt;/b&gt; / &lt;b&gt;Classes des bâtiments&lt;/b&gt; : codes de classification ASPRS, séparés par des virgules (sol 2, bâtiment 6 en LAS standard). Les points des autres classes sont ignorés.&lt;/p&gt;</translation>
    </message>
    <message>
      <source>lidar,las,laz,point cloud,classification,ahn,lidar hd</source>
      <translation>lidar,las,laz,nuage de points,classification,ahn,lidar hd</translation>
    </message>
    <message>
      <source>Writing the blocks and footprints</source>
      <translation>Écriture des îlots et de leurs emprises</translation>
    </message>
    <message>
      <source>Cancelled; no output was written.</source>
      <translation>Annulé ; aucune sortie n'a été écrite.</translation>
    </message>
    <message>
      <source>Could not connect to the Dask scheduler at {} ({}). Check that the scheduler is running and reachable at that address (tcp://host:port, by default port 8786), or leave the Dask scheduler address empty to run the tiles on local workers.</source>
      <translation>Connexion impossible à l'ordonnanceur Dask à l'adresse {} ({}). Vérifiez que l'ordonnanceur est lancé et joignable à cette adresse (tcp://hôte:port, par défaut le port 8786), ou laissez l'adresse de l'ordonnanceur Dask vide pour calculer les tuiles avec des processus locaux.</translation>
    </message>
    <message>
      <source>{} building blocks, total volume {:.1f} m³.</source>
      <translation>{} îlots bâtis, volume total {:.1f} m³.</translation>
    </message>
    <message>
      <source>Writing the ground</source>
      <translation>Écriture du sol</translation>
    </message>
    <message>
      <source>{} is a folder: choose a file.</source>
      <translation>{} est un dossier : choisissez un fichier.</translation>
    </message>
    <message>
      <source>File not found: {}</source>
      <translation>Fichier introuvable : {}</translation>
    </message>
    <message>
      <source>{} worker(s)</source>
      <translation>{} processus de calcul</translation>
    </message>
    <message>
      <source>The data fit in one tile of {} m: reconstructed in this process, without {}.</source>
      <translation>Les données tiennent dans une tuile de {} m : reconstruites dans ce processus, sans {}.</translation>
    </message>
    <message>
      <source>Mesh written to {}, preview to {}.</source>
      <translation>Maillage écrit dans {}, aperçu dans {}.</translation>
    </message>
    <message>
      <source>Could not write {}: {}</source>
      <translation>Impossible d'écrire {} : {}</translation>
    </message>
    <message>
      <source>The domain extent cannot be transformed from {} into the data's CRS {}: {}</source>
      <translation>L'emprise du domaine ne peut pas être transformée de {} dans le SCR des données {} : {}</translation>
    </message>
    <message>
      <source>Tiles of {} m on {}</source>
      <translation>Tuiles de {} m sur {}</translation>
    </message>
    <message>
      <source>Writing the mesh {}</source>
      <translation>Écriture du maillage {}</translation>
    </message>
    <message>
      <source>Could not remove the outputs written before the run stopped: {}</source>
      <translation>Impossible de supprimer les sorties écrites avant l'arrêt du traitement : {}</translation>
    </message>
    <message>
      <source>The mesh file {} has no mesh extension: end its name with one of {} (the extension picks the format).</source>
      <translation>Le fichier de maillage {} n'a pas d'extension de maillage : terminez son nom par l'une de {} (l'extension choisit le format).</translation>
    </message>
    <message>
      <source>The mesh file {} is a folder: give a file name inside it.</source>
      <translation>Le fichier de maillage {} est un dossier : donnez un nom de fichier à l'intérieur.</translation>
    </message>
    <message>
      <source>The folder of the mesh file {} does not exist: create it or choose another one.</source>
      <translation>Le dossier du fichier de maillage {} n'existe pas : créez-le ou choisissez-en un autre.</translation>
    </message>
    <message>
      <source>The folder of the mesh file {} cannot be written to: choose another one.</source>
      <translation>Le dossier du fichier de maillage {} n'est pas accessible en écriture : choisissez-en un autre.</translation>
    </message>
    <message>
      <source>No point cloud file given (INPUT).</source>
      <translation>Aucun fichier de nuage de points donné (INPUT).</translation>
    </message>
    <message>
      <source>The folder {} holds no LAS/LAZ file (.las, .laz).</source>
      <translation>Le dossier {} ne contient aucun fichier LAS/LAZ (.las, .laz).</translation>
    </message>
    <message>
      <source>File or folder not found: {}</source>
      <translation>Fichier ou dossier introuvable : {}</translation>
    </message>
    <message>
      <source>Not a LAS/LAZ file: {}</source>
      <translation>Pas un fichier LAS/LAZ : {}</translation>
    </message>
    <message>
      <source>The data fall into {} separate clusters, each reconstructed on its own grid; every cluster has its own ground and air volumes.</source>
      <translation>Les données forment {} groupes séparés, reconstruits chacun sur sa propre grille ; chaque groupe a ses propres volumes de sol et d'air.</translation>
    </message>
    <message>
      <source>face crossings</source>
      <translation>croisements de faces</translation>
    </message>
    <message>
      <source>Reading point cloud</source>
      <translation>Lecture du nuage de points</translation>
    </message>
    <message>
      <source>Reading mesh</source>
      <translation>Lecture du maillage</translation>
    </message>
    <message>
      <source>Sampling triangles</source>
      <translation>Échantillonnage des triangles</translation>
    </message>
    <message>
      <source>Ground level of every column</source>
      <translation>Niveau du sol de chaque colonne</translation>
    </message>
    <message>
      <source>Sorting voxels into ground, building and air</source>
      <translation>Classement des voxels en sol, bâti et air</translation>
    </message>
    <message>
      <source>Building blocks</source>
      <translation>Îlots bâtis</translation>
    </message>
    <message>
      <source>Eliminating unsupported boundary voxels</source>
      <translation>Élimination des voxels de bord non étayés par les données</translation>
    </message>
    <message>
      <source>Conforming surfaces</source>
      <translation>Surfaces conformes</translation>
    </message>
    <message>
      <source>Measuring the blocks</source>
      <translation>Mesure des îlots</translation>
    </message>
    <message>
      <source>Projecting nodes onto the data</source>
      <translation>Projection des nœuds sur les données</translation>
    </message>
    <message>
      <source>{} blocks</source>
      <translation>{} îlots</translation>
    </message>
    <message>
      <source>{} of the city model's {} buildings are in no block (below the thresholds, outside the extent, or less than a quarter of their plan area in any one block).</source>
      <translation>{} des {} bâtiments du modèle de ville ne sont dans aucun îlot (sous les seuils, hors de l'emprise, ou moins du quart de leur surface en plan dans un même îlot).</translation>
    </message>
    <message>
      <source>Dropped {} blocks below the thresholds (height {:g} m, footprint {:g} m², volume {:g} m³).</source>
      <translation>{} îlots sous les seuils écartés (hauteur {:g} m, emprise {:g} m², volume {:g} m³).</translation>
    </message>
    <message>
      <source>Smoothing ({} passes)</source>
      <translation>Lissage ({} passes)</translation>
    </message>
    <message>
      <source>Smoothing</source>
      <translation>Lissage</translation>
    </message>
    <message>
      <source>Filled {} roof-hole columns ({:.0f} m²) with no return under them.</source>
      <translation>{} colonnes de trous de toit sans retour sous elles remplies ({:.0f} m²).</translation>
    </message>
    <message>
      <source>Over {:.0%} of the building columns have air under a roof: the surfaces are probably not closed (missing walls let the air in) and the blocks are hollow. FILL_UNDER_ROOFS (--fill-under-roofs) fills every column up to its roof.</source>
      <translation>Plus de {:.0%} des colonnes de bâti ont de l'air sous un toit : les surfaces ne sont sans doute pas fermées (des murs manquants laissent entrer l'air) et les îlots sont creux. FILL_UNDER_ROOFS (--fill-under-roofs) remplit chaque colonne jusqu'à son toit.</translation>
    </message>
    <message>
      <source>Projecting block nodes</source>
      <translation>Projection des nœuds des îlots</translation>
    </message>
    <message>
      <source>Projecting ground nodes</source>
      <translation>Projection des nœuds du sol</translation>
    </message>
    <message>
      <source>Cluster {}/{}: {}</source>
      <translation>Groupe {}/{} : {}</translation>
    </message>
    <message>
      <source>{}: {}</source>
      <translation>{} : {}</translation>
    </message>
    <message>
      <source>nodal normals</source>
      <translation>normales aux nœuds</translation>
    </message>
    <message>
      <source>nearest data points</source>
      <translation>points de données les plus proches</translation>
    </message>
    <message>
      <source>quality control</source>
      <translation>contrôle de qualité</translation>
    </message>
    <message>
      <source>moving-least-squares planes</source>
      <translation>plans des moindres carrés mobiles</translation>
    </message>
    <message>
      <source>No building block in the result.</source>
      <translation>Aucun îlot bâti dans le résultat.</translation>
    </message>
    <message>
      <source>pass {} of {}</source>
      <translation>passe {} sur {}</translation>
    </message>
    <message>
      <source>Cutting the domain into tiles</source>
      <translation>Découpage du domaine en tuiles</translation>
    </message>
    <message>
      <source>Merging the tiles</source>
      <translation>Fusion des tuiles</translation>
    </message>
    <message>
      <source>Tile {}/{} done</source>
      <translation>Tuile {}/{} terminée</translation>
    </message>
    <message>
      <source>Tile {}/{}: {}</source>
      <translation>Tuile {}/{} : {}</translation>
    </message>
  </context>
</TS>
