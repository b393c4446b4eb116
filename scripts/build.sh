#!/usr/bin/env bash
# Configure and build ecmor (Release) into ./build. Installs the Debian packages first.
# Usage: scripts/build.sh [--runtime] [TARGET...]   (default: everything)
#   --runtime: install only the run-time packages (setup.sh runtime) and, in a new build directory,
#              configure without the tests and benchmarks; with TARGET ecmor_runtime (the
#              executable and the bundled plugins) it is what scripts/run_example.sh needs. A later
#              full build (scripts/test.sh) installs the rest and turns them on again.
# Environment: BUILD_DIR (default build), JOBS (default: number of cores), CI=true adds -Werror.
set -euo pipefail
cd "$(dirname "$0")/.."
profile=all
if [ "${1:-}" = "--runtime" ]; then
  profile=runtime
  shift
fi
bash scripts/setup.sh "$profile"
build_dir=${BUILD_DIR:-build}
jobs=${JOBS:-$(nproc)}
werror=OFF
if [ "${CI:-}" = "true" ]; then werror=ON; fi
generator=()
if command -v ninja >/dev/null 2>&1; then generator=(-G Ninja); fi
flags=(-DECMOR_WERROR=$werror)
if [ "$profile" = all ]; then
  flags+=(-DECMOR_BUILD_TESTS=ON -DECMOR_BUILD_BENCH=ON)
elif [ ! -f "$build_dir/CMakeCache.txt" ]; then
  flags+=(-DECMOR_BUILD_TESTS=OFF -DECMOR_BUILD_BENCH=OFF)
fi
# The Python module needs an interpreter that imports NumPy (setup.sh installs Debian's): when
# the python3 first on PATH (a pyenv or virtualenv shim) cannot, Debian's own is named.
if ! python3 -c 'import numpy' >/dev/null 2>&1 && [ -x /usr/bin/python3 ] &&
   /usr/bin/python3 -c 'import numpy' >/dev/null 2>&1; then
  flags+=(-DPython3_EXECUTABLE=/usr/bin/python3)
fi
if [ ! -f "$build_dir/CMakeCache.txt" ]; then
  cmake -S . -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release "${flags[@]}"
else
  cmake -S . -B "$build_dir" "${flags[@]}" >/dev/null
fi
targets=()
for t in "$@"; do targets+=(--target "$t"); done
cmake --build "$build_dir" -j "$jobs" "${targets[@]}"
