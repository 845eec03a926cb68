<?xml version="1.0" encoding="utf-8"?>
<!DOCTYPE TS>
<TS version="2.1" language="de">
  <context>
    <name>urbanvox</name>
    <message>
      <source>urbanvox: voxel building blocks from point clouds and meshes</source>
      <translation>urbanvox: Voxel-Gebäudeblöcke aus Punktwolken und Netzen</translation>
    </message>
    <message>
      <source>Point cloud files (LAS/LAZ)</source>
      <translation>Punktwolkendateien (LAS/LAZ)</translation>
    </message>
    <message>
      <source>CRS of the points (default: from the file header)</source>
      <translation>KBS der Punkte (Standard: aus dem Dateikopf)</translation>
    </message>
    <message>
      <source>Ground classes (comma-separated)</source>
      <translation>Bodenklassen (durch Kommas getrennt)</translation>
    </message>
    <message>
      <source>Building classes (comma-separated)</source>
      <translation>Gebäudeklassen (durch Kommas getrennt)</translation>
    </message>
    <message>
      <source>Voxel size (m)</source>
      <translation>Voxelgröße (m)</translation>
    </message>
    <message>
      <source>Minimum block height (m)</source>
      <translation>Minimale Blockhöhe (m)</translation>
    </message>
    <message>
      <source>Minimum block footprint (m²)</source>
      <translation>Minimale Blockgrundfläche (m²)</translation>
    </message>
    <message>
      <source>Minimum block volume (m³)</source>
      <translation>Minimales Blockvolumen (m³)</translation>
    </message>
    <message>
      <source>Domain extent (default: the data's)</source>
      <translation>Ausdehnung des Gebiets (Standard: die der Daten)</translation>
    </message>
    <message>
      <source>Smoothing passes (Catmull-Clark)</source>
      <translation>Glättungsdurchgänge (Catmull-Clark)</translation>
    </message>
    <message>
      <source>Project the smoothed surfaces onto the data</source>
      <translation>Geglättete Flächen auf die Daten projizieren</translation>
    </message>
    <message>
      <source>Minimum face quality (inradius / longest edge, 1 = equilateral)</source>
      <translation>Minimale Flächenqualität (Inkreisradius / längste Kante, 1 = gleichseitig)</translation>
    </message>
    <message>
      <source>Tile size (m, 0 = one grid)</source>
      <translation>Kachelgröße (m, 0 = ein Gitter)</translation>
    </message>
    <message>
      <source>Worker processes for the tiles (Dask)</source>
      <translation>Worker-Prozesse für die Kacheln (Dask)</translation>
    </message>
    <message>
      <source>Dask scheduler address (default: local workers)</source>
      <translation>Adresse eines Dask-Schedulers (Standard: lokale Worker)</translation>
    </message>
    <message>
      <source>Write a .msh mesh file in binary</source>
      <translation>Die .msh-Netzdatei binär schreiben</translation>
    </message>
    <message>
      <source>Building blocks (3D surfaces)</source>
      <translation>Gebäudeblöcke (3D-Flächen)</translation>
    </message>
    <message>
      <source>Building footprints</source>
      <translation>Grundrisse der Gebäudeblöcke</translation>
    </message>
    <message>
      <source>Ground surface</source>
      <translation>Geländeoberfläche</translation>
    </message>
    <message>
      <source>Conforming mesh file (blocks, ground, air)</source>
      <translation>Konformes Netz als Datei (Blöcke, Boden, Luft)</translation>
    </message>
    <message>
      <source>gmsh (*.msh);;VTK unstructured grid (*.vtu);;Wavefront OBJ (*.obj);;STL, one solid per region (*.stl);;PLY (*.ply)</source>
      <translation>gmsh (*.msh);;VTK-Gitter (*.vtu);;Wavefront OBJ (*.obj);;STL, ein Körper je Region (*.stl);;PLY (*.ply)</translation>
    </message>
    <message>
      <source>Preview picture (PNG)</source>
      <translation>Vorschaubild (PNG)</translation>
    </message>
    <message>
      <source>Number of building blocks</source>
      <translation>Anzahl der Gebäudeblöcke</translation>
    </message>
    <message>
      <source>Total volume of the blocks (m³)</source>
      <translation>Gesamtvolumen der Blöcke (m³)</translation>
    </message>
    <message>
      <source>ASPRS classification codes of the ground points, comma-separated (standard: 2).</source>
      <translation>ASPRS-Klassifizierungscodes der Bodenpunkte, durch Kommas getrennt (Standard: 2).</translation>
    </message>
    <message>
      <source>Classification codes of the building points, comma-separated (standard: 6); vegetation, noise and other codes are ignored.</source>
      <translation>Klassifizierungscodes der Gebäudepunkte, durch Kommas getrennt (Standard: 6); Vegetation, Rauschen und andere Codes werden ignoriert.</translation>
    </message>
    <message>
      <source>Edge of a voxel in metres. Details smaller than about a voxel disappear; halving it costs about 8 times the memory and time.</source>
      <translation>Kantenlänge eines Voxels in Metern. Details kleiner als etwa ein Voxel verschwinden; eine Halbierung kostet etwa das 8-Fache an Speicher und Zeit.</translation>
    </message>
    <message>
      <source>Blocks lower than this (m, top above the ground under them) are dropped.</source>
      <translation>Blöcke, die niedriger sind (m, Oberkante über dem Boden darunter), werden verworfen.</translation>
    </message>
    <message>
      <source>Blocks covering less ground than this (m²) are dropped.</source>
      <translation>Blöcke mit weniger Grundfläche (m²) werden verworfen.</translation>
    </message>
    <message>
      <source>Blocks smaller than this (m³) are dropped.</source>
      <translation>Blöcke mit kleinerem Volumen (m³) werden verworfen.</translation>
    </message>
    <message>
      <source>The domain: data outside is ignored, and blocks crossing its edge are closed on it. Default: the extent of the data. An extent in another CRS than the data's (drawn on a map, or typed with its CRS, e.g. [EPSG:4326]) is transformed into the data's, as its bounding box.</source>
      <translation>Das Gebiet: Daten außerhalb werden ignoriert, und Blöcke, die seinen Rand überschreiten, werden dort geschlossen. Standard: die Ausdehnung der Daten. Eine Ausdehnung in einem anderen KBS als dem der Daten (auf einer Karte gezeichnet oder mit ihrem KBS eingegeben, z. B. [EPSG:4326]) wird in das der Daten transformiert, als ihr umschließendes Rechteck.</translation>
    </message>
    <message>
      <source>Vertex-only Catmull-Clark passes over the voxel surfaces (the paper uses 3); 0 keeps the voxel faces.</source>
      <translation>Catmull-Clark-Durchgänge nur über die Knoten der Voxelflächen (der Artikel verwendet 3); 0 behält die Voxelflächen.</translation>
    </message>
    <message>
      <source>Move the smoothed nodes onto moving-least-squares planes of the data, along their normals.</source>
      <translation>Die geglätteten Knoten entlang ihrer Normalen auf gleitende Kleinste-Quadrate-Ebenen der Daten verschieben.</translation>
    </message>
    <message>
      <source>Smoothing and projection moves that would leave a face of lower quality (inradius / longest edge, 1 for an equilateral triangle, 0.72 for a voxel face) are refused.</source>
      <translation>Glättungs- und Projektionsschritte, die eine Fläche geringerer Qualität hinterlassen würden (Inkreisradius / längste Kante, 1 für ein gleichseitiges Dreieck, 0,72 für eine Voxelfläche), werden abgelehnt.</translation>
    </message>
    <message>
      <source>Cut the domain into square tiles of this side (m), each reconstructed on its own grid with a halo around it, then merged: for areas whose grid does not fit in memory, or to use several processes. A block crossing tiles is built whole by one tile; the result is the same as with one grid. 0: one grid.</source>
      <translation>Teilt das Gebiet in quadratische Kacheln dieser Seitenlänge (m), jede auf einem eigenen Gitter mit einem Rand rekonstruiert und danach zusammengeführt: für Gebiete, deren Gitter nicht in den Speicher passt, oder um mehrere Prozesse zu nutzen. Ein Block über mehrere Kacheln wird von einer Kachel ganz gebaut; das Ergebnis ist dasselbe wie mit einem Gitter. 0: ein Gitter.</translation>
    </message>
    <message>
      <source>The number of worker processes for the tiles (a local Dask cluster); without a tile size, tiles of 250 m. 0 or 1: the tiles run one after the other in QGIS's process. Needs the Python package dask[distributed].</source>
      <translation>Die Zahl der Worker-Prozesse für die Kacheln (ein lokaler Dask-Cluster); ohne Kachelgröße Kacheln von 250 m. 0 oder 1: die Kacheln laufen nacheinander im QGIS-Prozess. Benötigt das Python-Paket dask[distributed].</translation>
    </message>
    <message>
      <source>With tiles: the address of a running Dask scheduler (tcp://host:8786) whose workers have urbanvox's core importable; overrides the worker count.</source>
      <translation>Mit Kacheln: die Adresse eines laufenden Dask-Schedulers (tcp://host:8786), dessen Worker den Kern von urbanvox importieren können; ersetzt die Zahl der Worker.</translation>
    </message>
    <message>
      <source>Write the gmsh mesh file (.msh) in gmsh's binary encoding: the same content, read by gmsh and meshio, written faster on a city, and with exact coordinates (the text rounds them to 0.1 mm). The other mesh formats ignore it.</source>
      <translation>Schreibt die gmsh-Netzdatei (.msh) in der Binärkodierung von gmsh: derselbe Inhalt, von gmsh und meshio gelesen, auf einer Stadt schneller geschrieben, mit exakten Koordinaten (der Text rundet sie auf 0,1 mm). Die anderen Netzformate ignorieren es.</translation>
    </message>
    <message>
      <source>One feature per building block: its closed 3-D surface, with height, areas, volumes, mesh quality and distance to the data.</source>
      <translation>Ein Objekt je Gebäudeblock: seine geschlossene 3D-Oberfläche, mit Höhe, Flächen, Volumen, Netzqualität und Abstand zu den Daten.</translation>
    </message>
    <message>
      <source>One polygon per building block: the ground it covers, with the same fields.</source>
      <translation>Ein Polygon je Gebäudeblock: der Boden, den er bedeckt, mit denselben Feldern.</translation>
    </message>
    <message>
      <source>The terrain surface, in tiles of 64 x 64 voxels.</source>
      <translation>Die Geländeoberfläche, in Kacheln von 64 x 64 Voxeln.</translation>
    </message>
    <message>
      <source>Closed, conforming surfaces of every block, the ground and the air, for a finite-element or CFD mesher: .msh (gmsh, physical groups), .vtu, .obj, .stl or .ply. A PNG picture is written beside it.</source>
      <translation>Geschlossene, konforme Oberflächen jedes Blocks, des Bodens und der Luft für einen Finite-Elemente- oder CFD-Vernetzer: .msh (gmsh, physikalische Gruppen), .vtu, .obj, .stl oder .ply. Daneben wird ein PNG-Bild geschrieben.</translation>
    </message>
    <message>
      <source>One or several classified LAS/LAZ files (a tile collection, or a folder of them, is read as one cloud); the ground and building classes are chosen below.</source>
      <translation>Eine oder mehrere klassifizierte LAS/LAZ-Dateien (eine Kachelsammlung oder ein Ordner davon wird als eine Wolke gelesen); die Boden- und Gebäudeklassen werden weiter unten gewählt.</translation>
    </message>
    <message>
      <source>Coordinate reference system of the points, projected (metres or feet). Default: the one in the file header; required when the header has none (AHN3: EPSG:28992).</source>
      <translation>Koordinatenbezugssystem der Punkte, projiziert (Meter oder Fuß). Standard: das aus dem Dateikopf; erforderlich, wenn der Kopf keines enthält (AHN3: EPSG:28992).</translation>
    </message>
    <message>
      <source>Building mesh (STL/OBJ/PLY/OFF) or CityJSON</source>
      <translation>Gebäudenetz (STL/OBJ/PLY/OFF) oder CityJSON</translation>
    </message>
    <message>
      <source>Ground mesh</source>
      <translation>Geländenetz</translation>
    </message>
    <message>
      <source>CRS of the coordinates (required for STL/OBJ/PLY/OFF)</source>
      <translation>KBS der Koordinaten (erforderlich für STL/OBJ/PLY/OFF)</translation>
    </message>
    <message>
      <source>Fill every column up to its roof</source>
      <translation>Jede Säule bis zu ihrem Dach füllen</translation>
    </message>
    <message>
      <source>CityJSON level of detail (default: the highest)</source>
      <translation>CityJSON-Detaillierungsgrad (Standard: der höchste)</translation>
    </message>
    <message>
      <source>Optional terrain mesh, or a CityJSON file's terrain (TINRelief); without it the ground is a CityJSON input's own terrain, else it passes through the bottom of every building part.</source>
      <translation>Optionales Geländenetz oder das Gelände (TINRelief) einer CityJSON-Datei; ohne es ist der Boden das Gelände der CityJSON-Eingabe, sonst verläuft er durch die Unterkante jedes Gebäudeteils.</translation>
    </message>
    <message>
      <source>The level of detail a CityJSON file's buildings are taken at where they have it, as the file writes it (3D BAG: 1.2, 1.3 or 2.2); a coarser one makes a simpler mesh. Default: each building's highest.</source>
      <translation>Der Detaillierungsgrad, in dem die Gebäude einer CityJSON-Datei genommen werden, wo sie ihn haben, so geschrieben wie in der Datei (3D BAG: 1.2, 1.3 oder 2.2); ein gröberer ergibt ein einfacheres Netz. Standard: der höchste jedes Gebäudes.</translation>
    </message>
    <message>
      <source>Make every column solid from the ground up to its roof, as for airborne LiDAR: for city models whose walls are missing (the air would get in and leave the blocks hollow; the run warns of it). Passages and overhangs are filled too.</source>
      <translation>Jede Säule vom Boden bis zu ihrem Dach füllen, wie bei luftgestütztem LiDAR: für Stadtmodelle, denen Wände fehlen (die Luft dränge ein und ließe die Blöcke hohl; der Lauf warnt davor). Durchgänge und Auskragungen werden ebenfalls gefüllt.</translation>
    </message>
    <message>
      <source>A building mesh (STL, OBJ, PLY or OFF, of any quality: overlaps, gaps, inner surfaces) or a CityJSON file or sequence (.json, .jsonl), whose Building, BuildingPart and BuildingInstallation surfaces are read.</source>
      <translation>Ein Gebäudenetz (STL, OBJ, PLY oder OFF, in jeder Qualität: Überlappungen, Lücken, innere Flächen) oder eine CityJSON-Datei oder -Sequenz (.json, .jsonl), deren Flächen von Building, BuildingPart und BuildingInstallation gelesen werden.</translation>
    </message>
    <message>
      <source>Coordinate reference system of the coordinates, projected (metres or feet). Required for STL, OBJ, PLY and OFF, which carry none; a CityJSON file's referenceSystem is used when it is not set.</source>
      <translation>Koordinatenbezugssystem der Koordinaten, projiziert (Meter oder Fuß). Erforderlich für STL, OBJ, PLY und OFF, die keines tragen; das referenceSystem einer CityJSON-Datei wird verwendet, wenn es nicht gesetzt ist.</translation>
    </message>
    <message>
      <source>Reconstruct building blocks from mesh</source>
      <translation>Gebäudeblöcke aus einem Netz rekonstruieren</translation>
    </message>
    <message>
      <source>&lt;p&gt;Voxel building blocks from a triangle mesh of buildings, e.g. an STL exported from CityGML (also OBJ, PLY, OFF), or from a CityJSON city model (.json), whose buildings' polygons are triangulated. Triangles may overlap, intersect or leave gaps: they are sampled into points no farther apart than 10% of a voxel.&lt;/p&gt;&lt;p&gt;&lt;b&gt;Ground mesh&lt;/b&gt; [optional]: a mesh of the terrain, or a CityJSON file with a TINRelief; without it the ground is a CityJSON input's own terrain, if it has one, else it is taken under the lowest building points.&lt;br&gt;&lt;b&gt;CRS&lt;/b&gt;: required for STL, OBJ, PLY and OFF, which carry none; a CityJSON file's referenceSystem is used when it is not set.&lt;br&gt;&lt;b&gt;Fill every column up to its roof&lt;/b&gt; [advanced]: for models whose walls are missing, which the air fills (the run warns of hollow blocks).&lt;/p&gt;</source>
      <translation>&lt;p&gt;Voxel-Gebäudeblöcke aus einem Dreiecksnetz von Gebäuden, z. B. einem aus CityGML exportierten STL (auch OBJ, PLY, OFF), oder aus einem CityJSON-Stadtmodell (.json), dessen Gebäudepolygone trianguliert werden. Dreiecke dürfen sich überlappen, schneiden oder Lücken lassen: sie werden in Punkte mit höchstens 10 % eines Voxels Abstand abgetastet.&lt;/p&gt;&lt;p&gt;&lt;b&gt;Geländenetz&lt;/b&gt; [optional]: ein Netz des Geländes oder eine CityJSON-Datei mit einem TINRelief; ohne es ist der Boden das Gelände der CityJSON-Eingabe, falls sie eines hat, sonst wird er unter den tiefsten Gebäudepunkten angenommen.&lt;br&gt;&lt;b&gt;KBS&lt;/b&gt;: erforderlich für STL, OBJ, PLY und OFF, die keines tragen; das referenceSystem einer CityJSON-Datei wird verwendet, wenn es nicht gesetzt ist.&lt;br&gt;&lt;b&gt;Jede Säule bis zu ihrem Dach füllen&lt;/b&gt; [erweitert]: für Modelle, denen Wände fehlen, die die Luft füllt (der Lauf warnt vor hohlen Blöcken).&lt;/p&gt;</translation>
    </message>
    <message>
      <source>&lt;p&gt;The data are put in a grid of cubic voxels; voxels are sorted into ground, building and air (air is flood-filled from above, so closed courtyards and inner surfaces are handled); face-connected building voxels form a building block. Blocks lower, smaller or lighter than the thresholds are dropped.&lt;/p&gt;&lt;p&gt;&lt;b&gt;Voxel size&lt;/b&gt;: edge of a voxel in metres; halving it multiplies memory and time by ~8.&lt;br&gt;&lt;b&gt;Minimum height / footprint / volume&lt;/b&gt;: blocks below any of them are discarded.&lt;br&gt;&lt;b&gt;Smoothing passes&lt;/b&gt;: vertex-only Catmull-Clark passes (paper: 3); nodes at the foot of the walls keep their height. &lt;b&gt;Project&lt;/b&gt;: move the smoothed nodes onto moving-least-squares planes of the data. &lt;b&gt;Minimum face quality&lt;/b&gt;: a smoothing or projection move that would leave a worse face is refused (a voxel face scores 0.72).&lt;br&gt;&lt;b&gt;Domain extent&lt;/b&gt;: clip the data; blocks crossing it are closed on its sides.&lt;/p&gt;&lt;p&gt;&lt;b&gt;Blocks&lt;/b&gt;: one MultiPolygonZ per block, its closed outer surface (smoothed and projected). &lt;b&gt;Footprints&lt;/b&gt;: one polygon per block (the columns it covers). Both have the fields block_id, height, ground_z, top_z, footprint_area (m²), volume (m³), surface_area (m²) and n_voxels of the voxel model, then mesh_volume, mesh_area, roof_area, facade_area, min_quality, mean_quality, mean_dist and max_dist (m, nodes to the data) of the final mesh. &lt;b&gt;Ground surface&lt;/b&gt;: the terrain, in tiles. &lt;b&gt;Mesh file&lt;/b&gt;: closed, conforming surfaces of every block, the ground and the air; the extension picks the format (.msh with physical groups per interface and per region, .vtu, .obj, .stl, .ply); a PNG preview is written beside it.&lt;/p&gt;</source>
      <translation>&lt;p&gt;Die Daten werden in ein Gitter würfelförmiger Voxel gelegt; die Voxel werden in Boden, Gebäude und Luft eingeteilt (die Luft wird von oben geflutet, so werden geschlossene Innenhöfe und innere Flächen behandelt); über Flächen verbundene Gebäudevoxel bilden einen Block. Blöcke unter den Schwellenwerten werden verworfen.&lt;/p&gt;&lt;p&gt;&lt;b&gt;Voxelgröße&lt;/b&gt;: Kante eines Voxels in Metern; eine Halbierung vervielfacht Speicher und Zeit um ~8.&lt;br&gt;&lt;b&gt;Minimale Höhe / Grundfläche / Volumen&lt;/b&gt;: Blöcke unter einem davon werden verworfen.&lt;br&gt;&lt;b&gt;Glättungsdurchgänge&lt;/b&gt;: Catmull-Clark nur über die Knoten (Artikel: 3); Knoten am Fuß der Wände behalten ihre Höhe. &lt;b&gt;Projizieren&lt;/b&gt;: die geglätteten Knoten auf gleitende Kleinste-Quadrate-Ebenen der Daten verschieben. &lt;b&gt;Minimale Flächenqualität&lt;/b&gt;: ein Schritt, der eine schlechtere Fläche hinterließe, wird abgelehnt (eine Voxelfläche hat 0,72).&lt;br&gt;&lt;b&gt;Gebietsausdehnung&lt;/b&gt;: schneidet die Daten zu; Blöcke über den Rand werden an seinen Seiten geschlossen.&lt;/p&gt;&lt;p&gt;&lt;b&gt;Blöcke&lt;/b&gt;: ein MultiPolygonZ je Block, seine geschlossene Außenfläche (geglättet und projiziert). &lt;b&gt;Grundrisse&lt;/b&gt;: ein Polygon je Block (die Spalten, die er bedeckt). Beide haben die Felder block_id, height, ground_z, top_z, footprint_area (m²), volume (m³), surface_area (m²) und n_voxels des Voxelmodells, dann mesh_volume, mesh_area, roof_area, facade_area, min_quality, mean_quality, mean_dist und max_dist (m, Knoten zu den Daten) des endgültigen Netzes. &lt;b&gt;Geländeoberfläche&lt;/b&gt;: das Gelände, in Kacheln. &lt;b&gt;Netzdatei&lt;/b&gt;: geschlossene, konforme Oberflächen jedes Blocks, des Bodens und der Luft; die Endung wählt das Format (.msh mit physikalischen Gruppen je Grenzfläche und je Region, .vtu, .obj, .stl, .ply); daneben wird ein PNG-Vorschaubild geschrieben.&lt;/p&gt;</translation>
    </message>
    <message>
      <source>&lt;p&gt;From a CityJSON file, both layers also have the fields building_ids, the identifiers of the buildings each block holds, separated by ';' (a BuildingPart counts as its Building; a building is in every block that covers a quarter of its plan area or more), and n_buildings.&lt;/p&gt;</source>
      <translation>&lt;p&gt;Aus einer CityJSON-Datei haben beide Layer auch die Felder building_ids, die Kennungen der Gebäude, die jeder Block enthält, getrennt durch „;“ (ein BuildingPart zählt als sein Building; ein Gebäude gehört zu jedem Block, der mindestens ein Viertel seiner Grundrissfläche deckt), und n_buildings.&lt;/p&gt;</translation>
    </message>
    <message>
      <source>voxel,building,block,urban,city,3d,finite element,cfd,mesh,gmsh,catmull-clark</source>
      <translation>voxel,gebäude,block,städtisch,stadt,3d,finite elemente,cfd,netz,gmsh,catmull-clark</translation>
    </message>
    <message>
      <source>cityjson,citygml,city model,lod2,stl,obj,ply,3d bag</source>
      <translation>cityjson,citygml,stadtmodell,lod2,stl,obj,ply,3d bag</translation>
    </message>
    <message>
      <source>Reconstruct building blocks from point cloud</source>
      <translation>Gebäudeblöcke aus einer Punktwolke rekonstruieren</translation>
    </message>
    <message>
      <source>&lt;p&gt;Voxel building blocks from a classified LiDAR point cloud: one or several .las/.laz files (a tile collection, as LiDAR is delivered, is read as one cloud).&lt;/p&gt;&lt;p&gt;&lt;b&gt;CRS&lt;/b&gt;: the coordinate reference system of the points; by default the one in the file header. Required when the header has none (e.g. AHN3 tiles: EPSG:28992); it overrides the header.&lt;br&gt;&lt;b&gt;Ground classes&lt;/b&gt; / &lt;b&gt;Building classes&lt;/b&gt;: ASPRS classification codes, comma-separated (ground 2, building 6 in standard LAS). Points of other classes are ignored.&lt;/p&gt;</source>
      <translation>&lt;p&gt;Voxel-Gebäudeblöcke aus einer klassifizierten LiDAR-Punktwolke: eine oder mehrere .las/.laz-Dateien (eine Kachelsammlung, wie LiDAR geliefert wird, wird als eine Wolke gelesen).&lt;/p&gt;&lt;p&gt;&lt;b&gt;KBS&lt;/b&gt;: das Koordinatenbezugssystem der Punkte; standardmäßig das aus dem Dateikopf. Erforderlich, wenn der Kopf keines enthält (z. B. AHN3-Kacheln: EPSG:28992); es ersetzt das des Kopfes.&lt;br&gt;&lt;b&gt;Bodenklassen&lt;/b&gt; / &lt;b&gt;Gebäudeklassen&lt;/b&gt;: ASPRS-Klassifizierungscodes, durch Kommas getrennt (Boden 2, Gebäude 6 in Standard-LAS). Punkte anderer Klassen werden ignoriert.&lt;/p&gt;</translation>
    </message>
    <message>
      <source>lidar,las,laz,point cloud,classification,ahn,lidar hd</source>
      <translation>lidar,las,laz,punktwolke,klassifizierung,ahn,lidar hd</translation>
    </message>
    <message>
      <source>Writing the blocks and footprints</source>
      <translation>Blöcke und Grundrisse werden geschrieben</translation>
    </message>
    <message>
      <source>Cancelled; no output was written.</source>
      <translation>Abgebrochen; keine Ausgabe wurde geschrieben.</translation>
    </message>
    <message>
      <source>Could not connect to the Dask scheduler at {} ({}). Check that the scheduler is running and reachable at that address (tcp://host:port, by default port 8786), or leave the Dask scheduler address empty to run the tiles on local workers.</source>
      <translation>Keine Verbindung zum Dask-Scheduler unter {} ({}). Prüfen Sie, dass der Scheduler läuft und unter dieser Adresse erreichbar ist (tcp://Host:Port, standardmäßig Port 8786), oder lassen Sie die Adresse des Dask-Schedulers leer, um die Kacheln mit lokalen Worker-Prozessen zu berechnen.</translation>
    </message>
    <message>
      <source>{} building blocks, total volume {:.1f} m³.</source>
      <translation>{} Gebäudeblöcke, Gesamtvolumen {:.1f} m³.</translation>
    </message>
    <message>
      <source>Writing the ground</source>
      <translation>Gelände wird geschrieben</translation>
    </message>
    <message>
      <source>{} is a folder: choose a file.</source>
      <translation>{} ist ein Ordner: Wählen Sie eine Datei.</translation>
    </message>
    <message>
      <source>File not found: {}</source>
      <translation>Datei nicht gefunden: {}</translation>
    </message>
    <message>
      <source>{} worker(s)</source>
      <translation>{} Worker-Prozess(e)</translation>
    </message>
    <message>
      <source>The data fit in one tile of {} m: reconstructed in this process, without {}.</source>
      <translation>Die Daten passen in eine Kachel von {} m: in diesem Prozess rekonstruiert, ohne {}.</translation>
    </message>
    <message>
      <source>Mesh written to {}, preview to {}.</source>
      <translation>Netz nach {} geschrieben, Vorschau nach {}.</translation>
    </message>
    <message>
      <source>Could not write {}: {}</source>
      <translation>{} konnte nicht geschrieben werden: {}</translation>
    </message>
    <message>
      <source>The domain extent cannot be transformed from {} into the data's CRS {}: {}</source>
      <translation>Die Ausdehnung des Gebiets kann nicht von {} in das KBS der Daten {} transformiert werden: {}</translation>
    </message>
    <message>
      <source>Tiles of {} m on {}</source>
      <translation>Kacheln von {} m auf {}</translation>
    </message>
    <message>
      <source>Writing the mesh {}</source>
      <translation>Netz {} wird geschrieben</translation>
    </message>
    <message>
      <source>Could not remove the outputs written before the run stopped: {}</source>
      <translation>Die vor dem Abbruch geschriebenen Ausgaben konnten nicht entfernt werden: {}</translation>
    </message>
    <message>
      <source>The mesh file {} has no mesh extension: end its name with one of {} (the extension picks the format).</source>
      <translation>Die Netzdatei {} hat keine Netz-Endung: Beenden Sie ihren Namen mit einer von {} (die Endung wählt das Format).</translation>
    </message>
    <message>
      <source>The mesh file {} is a folder: give a file name inside it.</source>
      <translation>Die Netzdatei {} ist ein Ordner: Geben Sie einen Dateinamen darin an.</translation>
    </message>
    <message>
      <source>The folder of the mesh file {} does not exist: create it or choose another one.</source>
      <translation>Der Ordner der Netzdatei {} existiert nicht: Legen Sie ihn an oder wählen Sie einen anderen.</translation>
    </message>
    <message>
      <source>The folder of the mesh file {} cannot be written to: choose another one.</source>
      <translation>In den Ordner der Netzdatei {} kann nicht geschrieben werden: Wählen Sie einen anderen.</translation>
    </message>
    <message>
      <source>No point cloud file given (INPUT).</source>
      <translation>Keine Punktwolkendatei angegeben (INPUT).</translation>
    </message>
    <message>
      <source>The folder {} holds no LAS/LAZ file (.las, .laz).</source>
      <translation>Der Ordner {} enthält keine LAS/LAZ-Datei (.las, .laz).</translation>
    </message>
    <message>
      <source>File or folder not found: {}</source>
      <translation>Datei oder Ordner nicht gefunden: {}</translation>
    </message>
    <message>
      <source>Not a LAS/LAZ file: {}</source>
      <translation>Keine LAS/LAZ-Datei: {}</translation>
    </message>
    <message>
      <source>The data fall into {} separate clusters, each reconstructed on its own grid; every cluster has its own ground and air volumes.</source>
      <translation>Die Daten zerfallen in {} getrennte Gruppen, jede auf ihrem eigenen Gitter rekonstruiert; jede Gruppe hat ihre eigenen Boden- und Luftvolumen.</translation>
    </message>
    <message>
      <source>face crossings</source>
      <translation>Flächenüberschneidungen</translation>
    </message>
    <message>
      <source>Reading point cloud</source>
      <translation>Punktwolke wird gelesen</translation>
    </message>
    <message>
      <source>Reading mesh</source>
      <translation>Netz wird gelesen</translation>
    </message>
    <message>
      <source>Sampling triangles</source>
      <translation>Dreiecke werden abgetastet</translation>
    </message>
    <message>
      <source>Ground level of every column</source>
      <translation>Geländehöhe jeder Säule</translation>
    </message>
    <message>
      <source>Sorting voxels into ground, building and air</source>
      <translation>Voxel werden in Boden, Gebäude und Luft eingeteilt</translation>
    </message>
    <message>
      <source>Building blocks</source>
      <translation>Gebäudeblöcke</translation>
    </message>
    <message>
      <source>Eliminating unsupported boundary voxels</source>
      <translation>Nicht durch Daten gestützte Randvoxel werden entfernt</translation>
    </message>
    <message>
      <source>Conforming surfaces</source>
      <translation>Konforme Flächen</translation>
    </message>
    <message>
      <source>Measuring the blocks</source>
      <translation>Blöcke werden vermessen</translation>
    </message>
    <message>
      <source>Projecting nodes onto the data</source>
      <translation>Knoten werden auf die Daten projiziert</translation>
    </message>
    <message>
      <source>{} blocks</source>
      <translation>{} Blöcke</translation>
    </message>
    <message>
      <source>{} of the city model's {} buildings are in no block (below the thresholds, outside the extent, or less than a quarter of their plan area in any one block).</source>
      <translation>{} der {} Gebäude des Stadtmodells liegen in keinem Block (unter den Schwellen, außerhalb der Ausdehnung oder mit weniger als einem Viertel ihrer Grundrissfläche in einem Block).</translation>
    </message>
    <message>
      <source>Dropped {} blocks below the thresholds (height {:g} m, footprint {:g} m², volume {:g} m³).</source>
      <translation>{} Blöcke unter den Schwellen verworfen (Höhe {:g} m, Grundfläche {:g} m², Volumen {:g} m³).</translation>
    </message>
    <message>
      <source>Smoothing ({} passes)</source>
      <translation>Glättung ({} Durchgänge)</translation>
    </message>
    <message>
      <source>Smoothing</source>
      <translation>Glättung</translation>
    </message>
    <message>
      <source>Filled {} roof-hole columns ({:.0f} m²) with no return under them.</source>
      <translation>{} Dachlochsäulen ohne Rückmeldung darunter gefüllt ({:.0f} m²).</translation>
    </message>
    <message>
      <source>Over {:.0%} of the building columns have air under a roof: the surfaces are probably not closed (missing walls let the air in) and the blocks are hollow. FILL_UNDER_ROOFS (--fill-under-roofs) fills every column up to its roof.</source>
      <translation>Über {:.0%} der Gebäudesäulen haben Luft unter einem Dach: die Flächen sind wohl nicht geschlossen (fehlende Wände lassen die Luft hinein) und die Blöcke sind hohl. FILL_UNDER_ROOFS (--fill-under-roofs) füllt jede Säule bis zu ihrem Dach.</translation>
    </message>
    <message>
      <source>Projecting block nodes</source>
      <translation>Knoten der Blöcke werden projiziert</translation>
    </message>
    <message>
      <source>Projecting ground nodes</source>
      <translation>Knoten des Bodens werden projiziert</translation>
    </message>
    <message>
      <source>Cluster {}/{}: {}</source>
      <translation>Gruppe {}/{}: {}</translation>
    </message>
    <message>
      <source>{}: {}</source>
      <translation>{}: {}</translation>
    </message>
    <message>
      <source>nodal normals</source>
      <translation>Knotennormalen</translation>
    </message>
    <message>
      <source>nearest data points</source>
      <translation>nächste Datenpunkte</translation>
    </message>
    <message>
      <source>quality control</source>
      <translation>Qualitätskontrolle</translation>
    </message>
    <message>
      <source>moving-least-squares planes</source>
      <translation>Ebenen der gleitenden kleinsten Quadrate</translation>
    </message>
    <message>
      <source>No building block in the result.</source>
      <translation>Kein Gebäudeblock im Ergebnis.</translation>
    </message>
    <message>
      <source>pass {} of {}</source>
      <translation>Durchgang {} von {}</translation>
    </message>
    <message>
      <source>Cutting the domain into tiles</source>
      <translation>Das Gebiet wird in Kacheln geteilt</translation>
    </message>
    <message>
      <source>Merging the tiles</source>
      <translation>Kacheln werden zusammengeführt</translation>
    </message>
    <message>
      <source>Tile {}/{} done</source>
      <translation>Kachel {}/{} fertig</translation>
    </message>
    <message>
      <source>Tile {}/{}: {}</source>
      <translation>Kachel {}/{}: {}</translation>
    </message>
  </context>
</TS>
