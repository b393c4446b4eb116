#!/usr/bin/env bash
# Set everything up, build, and reduce the shipped example: the triple-chain oscillator
# (N = 451) reduced by the modal plugin to the smallest order meeting a 1e-3 relative band error.
# Usage: scripts/run_example.sh [CONFIG]   (default configs/triplechain_saak09_n451.yaml)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh --runtime ecmor_runtime
config=${1:-configs/triplechain_saak09_n451.yaml}
exec "${BUILD_DIR:-build}/bin/ecmor" reduce "$config"
