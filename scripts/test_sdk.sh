#!/usr/bin/env bash
# The SDK end to end, as a researcher does it: install an already-built ecmor into a temporary
# prefix, check the installed layout and driver, then configure, build and test the plugin template
# (examples/plugin-template) as a separate project against that prefix only. With the Python
# module built, the installed package is imported and must find the bundled plugins.
# Usage: scripts/test_sdk.sh [BUILD_DIR]      (default: $BUILD_DIR, else build; relative to the root)
# Environment: JOBS (default: number of cores), KEEP_SDK_TEST=1 keeps the temporary directory.
# The temporary directory is created under BUILD_DIR and removed on success; on failure it is kept
# and named, so the logs can be read. Nothing outside it is written; runs are independent.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
build_arg=${1:-${BUILD_DIR:-build}}
jobs=${JOBS:-$(nproc)}

say() { printf 'test_sdk: %s\n' "$*"; }
die() { printf 'test_sdk: FAILED: %s\n' "$*" >&2; exit 1; }

case $build_arg in
  /*) build_dir=$build_arg ;;
  *) build_dir=$root/$build_arg ;;
esac
[ -f "$build_dir/CMakeCache.txt" ] ||
  die "$build_dir is not a configured build tree (build first: bash scripts/build.sh)"
build_dir=$(cd "$build_dir" && pwd)

# What the install copies must exist: the driver and the four bundled plugins.
bundled=(modal krylov irka balanced)
[ -x "$build_dir/bin/ecmor" ] || die "$build_dir/bin/ecmor is missing (build the 'ecmor' target)"
for name in "${bundled[@]}"; do
  [ -f "$build_dir/lib/ecmor/plugins/libecmor_$name.so" ] ||
    die "$build_dir/lib/ecmor/plugins/libecmor_$name.so is missing (build 'ecmor_$name')"
done

work=$(mktemp -d "$build_dir/sdk-test.XXXXXX")
prefix=$work/prefix
finish() {
  local status=$?
  if [ "$status" -eq 0 ] && [ "${KEEP_SDK_TEST:-0}" != 1 ]; then
    rm -rf "$work"
  else
    say "logs and files kept in $work"
  fi
}
trap finish EXIT

say "installing $build_dir into $prefix"
cmake --install "$build_dir" --prefix "$prefix" >"$work/install.log" 2>&1 ||
  die "cmake --install failed, see $work/install.log"

for file in bin/ecmor lib/cmake/ecmor/ecmorConfig.cmake lib/cmake/ecmor/ecmorConfigVersion.cmake \
            lib/cmake/ecmor/ecmorTargets.cmake lib/cmake/ecmor/EcmorPlugin.cmake \
            include/ecmor/plugin/plugin.hpp include/ecmor/export.hpp include/ecmor/version.hpp \
            include/ecmor/interop/fe_geometry.hpp include/ecmor/interop/export.hpp; do
  [ -e "$prefix/$file" ] || die "the install has no $file"
done
for lib in core interop; do
  ls "$prefix"/lib/libecmor_$lib.so* >/dev/null 2>&1 || die "the install has no lib/libecmor_$lib.so"
done

# Every installed binary resolves its libraries, ours from the prefix (RPATH), not from the build
# tree: libecmor_core for all of them, libecmor_interop for the driver.
loads_from_prefix() {  # BINARY LIBRARY (the output of ldd BINARY on stdin)
  local found
  found=$(awk -v lib="$2" 'index($1, lib) == 1 {print $3}')
  case $found in
    "$prefix"/*) ;;
    *) die "$1 loads $2 from '${found:-nowhere}', not from $prefix/lib" ;;
  esac
}
for binary in "$prefix/bin/ecmor" "$prefix"/lib/ecmor/plugins/*.so; do
  deps=$(ldd "$binary") || die "ldd $binary failed"
  if grep -q 'not found' <<<"$deps"; then
    die "$binary: unresolved libraries: $(grep 'not found' <<<"$deps" | tr -s ' \t' ' ')"
  fi
  loads_from_prefix "$binary" libecmor_core <<<"$deps"
done
loads_from_prefix "$prefix/bin/ecmor" libecmor_interop < <(ldd "$prefix/bin/ecmor")

# The installed driver finds the bundled plugins next to itself (no environment help).
listing=$(env -u ECMOR_PLUGIN_PATH "$prefix/bin/ecmor" plugins 2>&1) ||
  die "the installed 'ecmor plugins' failed: $listing"
for name in "${bundled[@]}"; do
  grep -Eq "(^|[^a-z_])$name([^a-z_]|$)" <<<"$listing" ||
    die "the installed 'ecmor plugins' does not list '$name':"$'\n'"$listing"
done
say "installed driver lists ${bundled[*]}"

# The Python module, when the build has it: importable from the installed package directory alone,
# its extension loading libecmor_core and libecmor_interop from the prefix, and finding the bundled
# plugins by itself.
pydir=$(sed -n 's/^ECMOR_PYTHON_INSTALL_DIR:[A-Z]*=//p' "$build_dir/CMakeCache.txt")
python=$(sed -n 's/^Python3_EXECUTABLE:[A-Z]*=//p' "$build_dir/CMakeCache.txt")
if [ -n "$pydir" ] && [ -n "$python" ]; then
  extension=$(ls "$prefix/$pydir"/ecmor/_ecmor*.so 2>/dev/null) ||
    die "the install has no Python extension in $prefix/$pydir/ecmor"
  deps=$(ldd "$extension") || die "ldd $extension failed"
  loads_from_prefix "$extension" libecmor_core <<<"$deps"
  loads_from_prefix "$extension" libecmor_interop <<<"$deps"
  listing=$(cd "$work" && env -u ECMOR_PLUGIN_PATH PYTHONPATH="$prefix/$pydir" "$python" -c \
    'import ecmor; print(ecmor.__file__); print(" ".join(p["name"] for p in ecmor.plugins()))' 2>&1) ||
    die "importing the installed Python module failed: $listing"
  case $listing in
    "$prefix"/*) ;;
    *) die "python imported ecmor from elsewhere: $listing" ;;
  esac
  for name in "${bundled[@]}"; do
    grep -Eq "(^|[^a-z_])$name([^a-z_]|$)" <<<"$listing" ||
      die "the installed Python module does not list '$name':"$'\n'"$listing"
  done
  say "installed Python module ($pydir) lists ${bundled[*]}"
fi

generator=()
if command -v ninja >/dev/null 2>&1; then generator=(-G Ninja); fi
template=$root/examples/plugin-template
say "configuring $template against $prefix"
env -u ECMOR_PLUGIN_PATH cmake -S "$template" -B "$work/template" "${generator[@]}" \
  -DCMAKE_PREFIX_PATH="$prefix" -DECMOR_EXAMPLE_RUN_DIR="$root" >"$work/configure.log" 2>&1 ||
  die "configuring the template failed, see $work/configure.log"
grep -q "ecmor_DIR:PATH=$prefix/lib/cmake/ecmor" "$work/template/CMakeCache.txt" ||
  die "the template found another ecmor: $(grep ecmor_DIR "$work/template/CMakeCache.txt")"

# The YAML example must be among the tests (it is skipped when the benchmark models are not found).
tests=$(cd "$work/template" && ctest -N) || die "ctest -N failed in $work/template"
grep -q 'pod_snapshots.reduce_iss_so' <<<"$tests" ||
  die "the template's YAML test is not configured: no $root/models/iss_so?"

say "building the template"
cmake --build "$work/template" -j "$jobs" >"$work/build.log" 2>&1 ||
  die "building the template failed, see $work/build.log"

say "running the template's tests"
(cd "$work/template" && env -u ECMOR_PLUGIN_PATH ctest --output-on-failure --timeout 300) ||
  die "the template's tests failed (output above)"

# ecmor::interop is an exported target of its own: a tool built against the prefix alone writes
# and reads back a nodes.csv/dofs.csv pair through it. Not in a sanitized build: an executable of
# ours without the sanitizer runtime cannot load libraries built with it (the template's plugin
# is loaded by the sanitized driver instead).
sanitize=$(sed -n 's/^ECMOR_SANITIZE:[A-Z]*=//p' "$build_dir/CMakeCache.txt")
if [ -n "$sanitize" ]; then
  say "sanitized build ($sanitize): the ecmor::interop consumer is not built"
  say "passed"
  exit 0
fi
say "building a tool against ecmor::interop"
mkdir -p "$work/interop-src"
cat >"$work/interop-src/CMakeLists.txt" <<'CMAKE'
cmake_minimum_required(VERSION 3.25)
project(interop_consumer LANGUAGES CXX)
find_package(ecmor 0.1 CONFIG REQUIRED)
add_executable(geometry_round_trip main.cpp)
target_link_libraries(geometry_round_trip PRIVATE ecmor::interop)
CMAKE
cat >"$work/interop-src/main.cpp" <<'CPP'
#include <cstdio>
#include "ecmor/interop/fe_geometry.hpp"
int main(int, char** argv) {
  ecmor::FeGeometry g;
  g.nodes = {{1, 0.0, 0.0, 0.0}};
  g.dofs = {{1, 1, 1}, {2, 1, 2}};
  ecmor::write_fe_geometry(argv[1], g);
  const auto back = ecmor::read_fe_geometry(argv[1], 2);
  std::printf("%zu dofs\n", back ? back->dofs.size() : 0);
  return back && back->dofs.size() == 2 ? 0 : 1;
}
CPP
env -u ECMOR_PLUGIN_PATH cmake -S "$work/interop-src" -B "$work/interop" "${generator[@]}" \
  -DCMAKE_PREFIX_PATH="$prefix" >"$work/interop.log" 2>&1 &&
  cmake --build "$work/interop" >>"$work/interop.log" 2>&1 ||
  die "building against ecmor::interop failed, see $work/interop.log"
mkdir -p "$work/interop/geometry"
"$work/interop/geometry_round_trip" "$work/interop/geometry" >>"$work/interop.log" 2>&1 ||
  die "the tool built against ecmor::interop failed, see $work/interop.log"
say "passed"
