#!/usr/bin/env bash
# Set everything up, build, and run the test suite (all labels except `slow`).
# Usage: scripts/test.sh [extra ctest arguments]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
cd "${BUILD_DIR:-build}"
ctest --output-on-failure -LE slow -j "${JOBS:-$(nproc)}" --timeout 900 "$@"
