#!/usr/bin/env bash
# The demo (run by `make demo` after the setup): generate the synthetic district, reconstruct it
# headless with both urbanvox algorithms through qgis_process, and print the blocks found beside
# the known truth. Everything goes to demo-output/.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/env.sh"
cd "$URBANVOX_ROOT"

out="$URBANVOX_ROOT/demo-output"
rm -rf "$out"
mkdir -p "$out/data"
echo "== Synthetic district (EPSG:2056) -> demo-output/data"
.venv/bin/python -m core.synthetic "$out/data"

# run NAME ALGORITHM PARAM=VALUE...: both outputs go to demo-output/NAME.gpkg (layers blocks and
# footprints; the ogr: URI is what QGIS 3.22 accepts for a named layer in a sink), the JSON
# report to demo-output/NAME.json, the log to demo-output/NAME.log.
run() {
  local name=$1 alg=$2
  shift 2
  local gpkg="$out/$name.gpkg"
  echo "== urbanvox:$alg -> demo-output/$name.gpkg"
  if ! scripts/qgis-process --json run "urbanvox:$alg" -- "$@" \
      "OUTPUT_BLOCKS=ogr:dbname='$gpkg' table=\"blocks\" (geom)" \
      "OUTPUT_FOOTPRINTS=ogr:dbname='$gpkg' table=\"footprints\" (geom)" \
      "OUTPUT_GROUND=ogr:dbname='$gpkg' table=\"ground\" (geom)" \
      "OUTPUT_MESH=$out/$name.msh" \
      >"$out/$name.json" 2>"$out/$name.log"; then
    cat "$out/$name.log" >&2
    echo "urbanvox:$alg failed; log above (demo-output/$name.log)" >&2
    exit 1
  fi
  .venv/bin/python scripts/show_blocks.py "$gpkg" --report "$out/$name.json" --truth "$out/data/truth.json"
}

run pointcloud reconstructfrompointcloud "INPUT=$out/data/district.laz" VOXEL_SIZE=1.0
# The district's STL is not clipped at the district's edge (its border building runs past it):
# the extent clips it like the point cloud.
extent=$(.venv/bin/python -c 'import json,sys; x0,y0,x1,y1=json.load(open(sys.argv[1]))["extent"]; print(f"{x0},{x1},{y0},{y1} [EPSG:2056]")' "$out/data/truth.json")
run mesh reconstructfrommesh "INPUT=$out/data/district.stl" "GROUND=$out/data/district_ground.stl" \
  CRS=EPSG:2056 VOXEL_SIZE=1.0 "EXTENT=$extent"
echo "== Done. In demo-output/:"
echo "   pointcloud.gpkg, mesh.gpkg   layers blocks, footprints, ground (open them in QGIS)"
echo "   pointcloud.msh, mesh.msh     gmsh meshes: a physical surface per interface, a physical volume per region"
echo "   pointcloud.png, mesh.png     pictures: the voxel model beside the smoothed, projected one"
