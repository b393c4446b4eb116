#pragma once
// petsc_solver.hpp: the interface between libecmor_core and the PETSc backend module
// (libecmor_petsc.so, built from petsc_solver.cpp when PETSc with complex scalars and MUMPS is
// found). Private to ecmor.
//
// Why a module loaded at run time: Debian's Ipopt (used by minimax_points) links the sequential
// MUMPS, whose stub MPI functions (mpi_allreduce_, ...) come first in the process's global symbol
// scope; PETSc's parallel MUMPS would bind to those stubs and fail ("ERROR in MPI_ALLREDUCE").
// The module is opened with RTLD_LOCAL | RTLD_DEEPBIND, so PETSc, MUMPS and MPI resolve their
// symbols among themselves first, and a run without the PETSc backend never loads them.
#include <memory>

#include "ecmor/model.hpp"
#include "ecmor/shifted_solver.hpp"

namespace ecmor::detail {

/// What the module offers (one static table; every function is safe to call only after
/// make_solver succeeded, which starts MPI and PETSc).
struct PetscBackendApi {
  int version;  ///< kPetscBackendApiVersion of the module's build
  /// \throws NumericalError with PETSc's message when PETSc cannot start or assemble.
  std::unique_ptr<ShiftedSolver> (*make_solver)(const Model& model);
  int (*rank)();
  int (*size)();
  bool (*any)(bool local);  ///< collective OR
  [[noreturn]] void (*abort)(int code);
};

constexpr int kPetscBackendApiVersion = 1;

/// Loads the module (once) and makes the distributed solver.
/// \throws ConfigError when this build or installation has no PETSc backend.
std::unique_ptr<ShiftedSolver> make_petsc_solver(const Model& model);

}  // namespace ecmor::detail

/// The module's entry point.
extern "C" const ecmor::detail::PetscBackendApi* ecmor_petsc_backend();
