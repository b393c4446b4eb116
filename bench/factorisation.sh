#!/usr/bin/env bash
# One complex factorisation plus solve of a 3-D solid under each BLAS, ordering and method
# (issue 27; the table "Sparse factorisation of 3-D solids" in docs/benchmarks.md).
# Usage: bench/factorisation.sh [MODEL_DIR] [F_HZ]
#   MODEL_DIR default: a clamped 140 x 14 x 7 hexahedral solid (N = 50 400), generated into
#   ${TMPDIR:-/tmp}/ecmor_solid_50k when absent. F_HZ default 1000.
# Every run is its own process (its peak memory is the method's). Run on an otherwise idle machine.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${BUILD_DIR:-build}/bin
model=${1:-${TMPDIR:-/tmp}/ecmor_solid_50k}
f_hz=${2:-1000}
if [ ! -f "$model/K.mtx" ]; then "$bin/ecmor_bench_models" solid 140 14 7 "$model"; fi
# Debian's reference BLAS and LAPACK, whatever the alternatives point to.
reference="/usr/lib/x86_64-linux-gnu/blas:/usr/lib/x86_64-linux-gnu/lapack"
openblas=$(dirname "$(readlink -f /usr/lib/x86_64-linux-gnu/libblas.so.3)")
for blas in reference default; do
  if [ $blas = reference ]; then path=$reference; else path=""; fi
  echo "== BLAS: $blas ($( [ $blas = reference ] && echo "$reference" || echo "$openblas"))"
  for run in "amd lu" "auto lu" "auto ldlt"; do
    set -- $run
    LD_LIBRARY_PATH=$path "$bin/ecmor_bench_factorisation" "$model" "$f_hz" --ordering "$1" \
      --complex-symmetric "$2" --repeat 3
  done
done
