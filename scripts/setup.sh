#!/usr/bin/env bash
# Install the build and run-time dependencies of ecmor from Debian 12 packages.
# Usage: scripts/setup.sh [runtime|fe|all]   (default all)
#   runtime: what the executable and the bundled plugins need (scripts/run_example.sh): a fresh
#            machine's first run does not wait for the test, sanitizer, FE and MPI/PETSc packages;
#   fe:      runtime and the programs of the CalculiX import pipeline (`ecmor import calculix`
#            runs ccx; examples/calculix-beam meshes with gmsh, which brings OpenCASCADE and X11
#            libraries: about 130 packages, kept out of the first run; jq for
#            examples/multibody/run.sh);
#   all:     fe and GoogleTest, Google Benchmark, clang (fuzzing, sanitizers), PETSc/SLEPc over
#            Open MPI (the optional backend), the Python module's build and test packages.
# Idempotent: packages already present are skipped; safe to run repeatedly.
# Needs root (or sudo) and the Debian package registry; downloads nothing else.
# OpenBLAS (its OpenMP build) comes with them: Debian's alternatives put it behind libblas.so.3
# and liblapack.so.3, and it makes the sparse factorisations of 3-D models an order of magnitude
# faster than the reference BLAS (docs/benchmarks.md). ECMOR_OPENBLAS=0 leaves it out; the
# README's testing section says how to run the suite under the reference BLAS instead.
set -euo pipefail

profile=${1:-all}
case "$profile" in
  runtime|fe|all) ;;
  *) echo "setup: unknown profile '$profile': use runtime, fe or all" >&2; exit 2 ;;
esac

packages=(
  build-essential cmake pkg-config ninja-build
  libeigen3-dev
  libsuitesparse-dev
  libarpack2-dev liblapack-dev libblas-dev
  libmumps-seq-dev   # sequential MUMPS: complex symmetric LDL^T factorisations
  libnlopt-dev libnlopt-cxx-dev
  coinor-libipopt-dev
  libyaml-cpp-dev
  libboost-dev libboost-filesystem-dev
  libfmt-dev
  libcli11-dev
  nlohmann-json3-dev
  libmatio-dev       # MATLAB .mat models and outputs (core/src/model/mat_file.cpp)
  zlib1g-dev         # gzip'ed Matrix Market models, .mtx.gz (core/src/base/gzip.cpp)
  gnuplot-nox
)
if [ "$profile" != runtime ]; then
  packages+=(calculix-ccx gmsh)   # `ecmor import calculix` runs ccx; the example meshes with gmsh
  packages+=(jq)                  # examples/multibody/run.sh (the test multibody_sid_pipeline) reads JSON
fi
if [ "$profile" = all ]; then
  packages+=(
    libgtest-dev libgmock-dev googletest
    libbenchmark-dev
    libspdlog-dev
    clang-14 libclang-rt-14-dev libomp-14-dev   # scripts/fuzz.sh, scripts/sanitize.sh: libFuzzer, the sanitizers, OpenMP
    clang-format-14                             # scripts/format.sh, the test format_check
    python3                                     # the tests layout_check and no_outside_paths
    python3-dev pybind11-dev python3-numpy      # the Python module (python/, docs/python.md)
    python3-scipy python3-pytest python3-yaml   # its tests (tests/python/)
    libpetsc-complex-dev openmpi-bin   # the PETSc backend (complex scalars, MUMPS) over MPI
    libslepc-complex-dev               # its distributed eigensolver (modal reducer)
  )
fi
if [ "${ECMOR_OPENBLAS:-1}" = 1 ]; then packages+=(libopenblas0-openmp); fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} Debian packages ($profile) already installed"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
    echo "setup: need root to install: ${missing[*]}" >&2; exit 1
  fi
fi

echo "setup: installing ${#missing[@]} package(s): ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "setup: done"
