#!/usr/bin/env bash
# Install every build and run-time dependency of ecmor from Debian 12 packages.
# Idempotent: packages already present are skipped; safe to run repeatedly.
# Needs root (or sudo) and the Debian package registry; downloads nothing else.
# OpenBLAS (its OpenMP build) comes with them: Debian's alternatives put it behind libblas.so.3
# and liblapack.so.3, and it makes the sparse factorisations of 3-D models an order of magnitude
# faster than the reference BLAS (docs/benchmarks.md). ECMOR_OPENBLAS=0 leaves it out; the
# README's testing section says how to run the suite under the reference BLAS instead.
set -euo pipefail

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
  libgtest-dev libgmock-dev googletest
  libbenchmark-dev
  libspdlog-dev libfmt-dev
  libcli11-dev
  nlohmann-json3-dev
  libmatio-dev
  gnuplot-nox
  clang-14 libclang-rt-14-dev libomp-14-dev   # scripts/fuzz.sh, scripts/sanitize.sh: libFuzzer, the sanitizers, OpenMP
  libpetsc-complex-dev openmpi-bin   # the PETSc backend (complex scalars, MUMPS) over MPI
  libslepc-complex-dev               # its distributed eigensolver (modal reducer)
)
if [ "${ECMOR_OPENBLAS:-1}" = 1 ]; then packages+=(libopenblas0-openmp); fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} Debian packages already installed"
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
