#!/usr/bin/env bash
# Configure and build ecmor (Release) into ./build. Installs the Debian packages first.
# Usage: scripts/build.sh [TARGET...]   (default: everything; ecmor_runtime = the executable and
#        the bundled plugins only, what scripts/run_example.sh needs)
# Environment: BUILD_DIR (default build), JOBS (default: number of cores), CI=true adds -Werror.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
build_dir=${BUILD_DIR:-build}
jobs=${JOBS:-$(nproc)}
werror=OFF
if [ "${CI:-}" = "true" ]; then werror=ON; fi
generator=()
if command -v ninja >/dev/null 2>&1; then generator=(-G Ninja); fi
if [ ! -f "$build_dir/CMakeCache.txt" ]; then
  cmake -S . -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DECMOR_WERROR=$werror
else
  cmake -S . -B "$build_dir" -DECMOR_WERROR=$werror >/dev/null
fi
targets=()
for t in "$@"; do targets+=(--target "$t"); done
cmake --build "$build_dir" -j "$jobs" "${targets[@]}"
