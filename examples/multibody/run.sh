#!/usr/bin/env bash
# mesh -> CalculiX -> ecmor -> SID on the steel cantilever of examples/calculix-beam
# (docs/multibody.md):
#   1. examples/calculix-beam/run.sh meshes, imports the clamped beam (model/) and reduces it;
#   2. the same deck without its *BOUNDARY card is imported as the mass model (model_free/);
#   3. `ecmor reduce reduce_modal.yaml` reduces the clamped beam with eigenmodes;
#   4. `ecmor export-body` writes body.SID_FEM and body.json;
#   5. the mass in the SID file is checked against rho V = 7800 kg/m^3 * 1 m * 0.03 m * 0.05 m;
#   6. the free beam (model_free) is reduced as a free-floating body (reduce_free.yaml) and
#      exported: six rigid-body motions in the frame, the elastic modes as coordinates;
#   7. with gnuplot, the shapes of the first four modes along the beam are drawn to PNG.
# Usage: examples/multibody/run.sh [ECMOR] [WORK_DIR] [PNG]
#   ECMOR     the ecmor executable (default build/bin/ecmor)
#   WORK_DIR  where everything is written (default out/multibody)
#   PNG       the picture (default WORK_DIR/modes.png; docs/img/multibody_modes.png is this)
# Needs gmsh, ccx and jq; gnuplot for the picture (skipped with a note when missing).
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
ecmor=$(realpath "${1:-build/bin/ecmor}")
work=$(realpath -m "${2:-out/multibody}")
png=$(realpath -m "${3:-$work/modes.png}")
command -v jq >/dev/null || { echo "run.sh: jq not found" >&2; exit 1; }

bash "$here/../calculix-beam/run.sh" "$ecmor" "$work"
cd "$work"
# The mass model: the deck without the *BOUNDARY card and its data lines.
awk '/^\*/ && !/^\*\*/ { card = toupper($0); gsub(/ /, "", card); skip = card ~ /^\*BOUNDARY/ }
     !skip' beam.inp > beam_free.inp
"$ecmor" import calculix "$here/import_free.yaml" -q
set +e
"$ecmor" reduce "$here/reduce_modal.yaml" --no-plot --quiet
status=$?
set -e
if [ "$status" -ne 0 ]; then echo "run.sh: reduce_modal.yaml ended with exit $status" >&2; exit 1; fi
"$ecmor" export-body reduced_modal --mass-model model_free --all-nodes -o body.SID_FEM

# The body's mass is the beam's: exact for the consistent mass up to ccx's 14 printed digits.
jq -e '(.mass - 7800 * 1.0 * 0.03 * 0.05) | fabs < 1e-9 * 11.7' body.json >/dev/null ||
  { echo "run.sh: mass $(jq .mass body.json) differs from rho V = 11.7 kg" >&2; exit 1; }
echo "mass $(jq .mass body.json) kg = rho V; centre of mass $(jq -c '[.mc.a0[][0] / .mass]' body.json) m"

# The free-floating beam: the rigid-body motion goes to the body frame, the elastic modes stay.
set +e
"$ecmor" reduce "$here/reduce_free.yaml" --no-plot --quiet
status=$?
set -e
if [ "$status" -ne 0 ]; then echo "run.sh: reduce_free.yaml ended with exit $status" >&2; exit 1; fi
"$ecmor" export-body reduced_free -o body_free.SID_FEM
order=$(jq .final_order reduced_free/summary.json)
jq -e --argjson n "$order" '.free_rigid_motions == 6 and .removed_coordinates == 6 and
    (.Me | length) == $n - 6 and ((.mass - 11.7) | fabs) < 1e-9 * 11.7' body_free.json >/dev/null ||
  { echo "run.sh: the free body has $(jq -c '[.free_rigid_motions, .removed_coordinates, (.Me | length)]' body_free.json) (free motions, removed, coordinates) for order $order" >&2; exit 1; }
echo "free-floating: order $order, $((order - 6)) elastic coordinates in body_free.SID_FEM"

if ! command -v gnuplot >/dev/null; then
  echo "run.sh: gnuplot not found: no picture"
  exit 0
fi
# Nodes on the line y = 0.015, z = 0.025 (the centre line of the section), sorted by x; columns:
# x, then for modes 1..4 the translation in the mode's dominant direction (y or z).
axis='[.frame_nodes[] | select((.position[1][0] - 0.015 | fabs) < 1e-9 and
                                (.position[2][0] - 0.025 | fabs) < 1e-9)] | sort_by(.position[0][0])'
dirs="($axis)"' as $n | [range(0; 4) | . as $k |
  if ([$n[].phi[1][$k] | fabs] | max) > ([$n[].phi[2][$k] | fabs] | max) then 1 else 2 end]'
jq -r "($dirs)"' as $d | '"($axis)"' | .[] | [.position[0][0]] + [range(0; 4) as $k | .phi[$d[$k]][$k]]
  | @tsv' body.json > axis.tsv
title() {
  jq -r --argjson k "$1" "($dirs)"' as $d | "\(.ielastq[$k] | sub("ecmor mode "; "mode ")), in \(if $d[$k] == 1 then "y" else "z" end)"' body.json
}
# One panel per direction: the first bending modes in y and in z have the same mass-normalised
# shape (at different frequencies) and would hide each other in one panel.
plots() {  # the plot commands of the modes whose dominant direction is $1 (1: y, 2: z)
  local cmd="" k
  for k in 0 1 2 3; do
    if [ "$(jq -r "($dirs)"' | .['"$k"']' body.json)" = "$1" ]; then
      cmd="$cmd${cmd:+, }\"axis.tsv\" using 1:$((k + 2)) with linespoints title \"$(title "$k")\""
    fi
  done
  echo "${cmd:-0 notitle}"
}
gnuplot <<GP
set terminal pngcairo size 1000,450 font ",11"
set output "$png"
set multiplot layout 1,2 title "Clamped steel beam (CalculiX C3D20): the SID body's first four coordinates along its axis"
set xlabel "x [m]"
set ylabel "translation (mass-normalised)"
set key bottom left
set grid
set datafile separator "\t"
set title "in y"
plot $(plots 1)
set title "in z"
plot $(plots 2)
unset multiplot
GP
echo "wrote $png"
