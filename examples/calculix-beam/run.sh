#!/usr/bin/env bash
# The gmsh -> CalculiX -> ecmor pipeline on a steel cantilever:
#   1. gmsh meshes beam.geo into a CalculiX/Abaqus deck (20-node hexahedra, node sets from the
#      physical groups);
#   2. the volume elements and the sets are kept (gmsh also writes the physical surfaces as
#      2-D elements, which would need sections of their own in ccx) and clamp.inp is appended;
#   3. `ecmor import calculix import.yaml` runs ccx and writes the model directory `model/`;
#   4. `ecmor reduce reduce.yaml` reduces it to the tolerance of reduce.yaml.
# Usage: examples/calculix-beam/run.sh [ECMOR] [WORK_DIR]
#   ECMOR     the ecmor executable (default build/bin/ecmor)
#   WORK_DIR  where everything is written (default out/calculix-beam); created if missing.
# Needs gmsh and ccx (Debian gmsh, calculix-ccx: scripts/setup.sh installs both).
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
ecmor=$(realpath "${1:-build/bin/ecmor}")
work=${2:-out/calculix-beam}
for tool in gmsh ccx; do
  if ! command -v "$tool" >/dev/null; then
    echo "run.sh: $tool not found: bash scripts/setup.sh fe installs it" >&2
    exit 1
  fi
done
mkdir -p "$work"
cd "$work"

gmsh -3 -order 2 -setnumber Mesh.SecondOrderIncomplete 1 -setnumber Mesh.SaveGroupsOfNodes 1 \
  -format inp -o mesh.inp "$here/beam.geo" > gmsh.log

# Keep *NODE, the C3D* element blocks, every *NSET and the element set BEAM; drop the rest.
awk '
  /^\*/ && !/^\*\*/ {
    card = toupper($0); gsub(/ /, "", card)
    keep = card ~ /^\*NODE/ || card ~ /^\*NSET/ || card ~ /^\*ELSET,ELSET=BEAM$/ ||
           (card ~ /^\*ELEMENT/ && card ~ /TYPE=C3D/)
  }
  keep' mesh.inp > beam.inp
cat "$here/clamp.inp" >> beam.inp

"$ecmor" import calculix "$here/import.yaml"
"$ecmor" reduce "$here/reduce.yaml" --no-plot --quiet
