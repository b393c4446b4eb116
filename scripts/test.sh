#!/usr/bin/env bash
# Set everything up, build, and run the test suite (all labels except `slow`).
# Usage: scripts/test.sh [extra ctest arguments]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
cd "${BUILD_DIR:-build}"
# One set of BLAS kernels for every machine. OpenBLAS chooses its kernels by CPU (Haswell for
# AVX2, SkylakeX for AVX-512, ...), and they round differently. Most of the suite does not care,
# but the failure atlas's pathological models (undamped, repeated and clustered modes:
# tests/stability, docs/failure-atlas.md) and targets at the rounding floor change their orders
# and outcomes with the last bits: on an AVX-512 machine (2026-11-30) the atlas's documented table
# differed in 3 and in 14 rows in two runs (negative_stiffness / krylov missed instead of
# converged) and passed with the Haswell kernels, on which it was generated. So on a CPU with
# AVX2 the suite runs with those, unless OPENBLAS_CORETYPE is set; without AVX2 OpenBLAS chooses
# as always.
if [ -z "${OPENBLAS_CORETYPE:-}" ] && grep -qw avx2 /proc/cpuinfo 2>/dev/null; then
  export OPENBLAS_CORETYPE=Haswell
fi
ctest --output-on-failure -LE slow -j "${JOBS:-$(nproc)}" --timeout 900 "$@"
