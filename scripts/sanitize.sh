#!/usr/bin/env bash
# Build ecmor with AddressSanitizer + UndefinedBehaviorSanitizer (clang-14) in build-asan/ and run the
# test suite there. Any sanitizer report aborts the process, so it fails its test.
# Usage: scripts/sanitize.sh [extra ctest arguments]
# Environment: BUILD_DIR (default build-asan), JOBS (default: number of cores).
# Excluded: the `slow` label (as in scripts/test.sh) and the `fuzz` label (the fuzz targets are
# already built with the sanitizers, by clang, in scripts/fuzz.sh). See docs/sanitizers.md.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
build_dir=${BUILD_DIR:-build-asan}
jobs=${JOBS:-$(nproc)}
generator=()
if command -v ninja >/dev/null 2>&1; then generator=(-G Ninja); fi
if [ ! -f "$build_dir/CMakeCache.txt" ]; then
  # clang-14 at -O1 with line tables: the sanitized build of every target takes about 5x less
  # compile time than GCC at -O2 -g (measured on core/src/measures/band_error.cpp: 36 s against 165 s),
  # and -O1 is what AddressSanitizer recommends. scripts/setup.sh installs clang-14 and libomp.
  cmake -S . -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
    -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1" -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1" \
    -DECMOR_SANITIZE=address,undefined -DECMOR_BUILD_BENCH=ON
fi
# Without the PETSc backend: its module is opened with RTLD_DEEPBIND, which AddressSanitizer does
# not support (and MPI's own allocations are not ours to check).
cmake -S . -B "$build_dir" -DECMOR_WITH_PETSC=OFF >/dev/null
cmake --build "$build_dir" -j "$jobs"
# halt_on_error: the first report ends the process; detect_leaks: LeakSanitizer at exit;
# print_stacktrace: UBSan reports carry the call stack. exitcode=86: a report in an `ecmor` child
# process of a CLI test must not exit with 1, the code of a correctly reported input error that
# those tests expect (the sanitizers' default is 1, and a leak found at exit would then pass).
export ASAN_OPTIONS="halt_on_error=1:detect_leaks=1:abort_on_error=0:exitcode=86:${ASAN_OPTIONS:-}"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:exitcode=86:${UBSAN_OPTIONS:-}"
cd "$build_dir"
ctest --output-on-failure -LE 'slow|fuzz' -j "$jobs" --timeout 2700 "$@"
