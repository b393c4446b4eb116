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

#include "ecmor/linalg/eigensolver.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/model.hpp"

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
  void (*abort)(int code);  ///< ends every rank; does not return
  /// SLEPc's Krylov-Schur on K phi = lambda M phi in shift-invert form, applying the MUMPS
  /// factorisation `factorization` of K - sigma M (made by this module's solver); the result has
  /// the meaning of ecmor::symmetric_shift_invert. Null when the module was built without SLEPc.
  SymmetricEigenResult (*symmetric_eigs)(const Factorization& factorization, const SparseMatrix& M,
                                         double sigma, const EigenOptions& options);
};

constexpr int kPetscBackendApiVersion = 2;

/// Loads the module (once) and makes the distributed solver.
/// \throws ConfigError when this build or installation has no PETSc backend.
std::unique_ptr<ShiftedSolver> make_petsc_solver(const Model& model);

/// True when `factorization` was made by the PETSc backend and the module has SLEPc: then
/// symmetric_shift_invert hands the problem to petsc_symmetric_eigs.
bool petsc_has_eigensolver(const Factorization& factorization);
SymmetricEigenResult petsc_symmetric_eigs(const Factorization& factorization, const SparseMatrix& M,
                                          double sigma, const EigenOptions& options);

}  // namespace ecmor::detail

/// The module's entry point.
extern "C" const ecmor::detail::PetscBackendApi* ecmor_petsc_backend();
