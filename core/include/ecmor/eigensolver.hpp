#pragma once
/// \file eigensolver.hpp
/// Shift-invert eigensolvers (ARPACK-ng) on top of a Factorization from the ShiftedSolver, so that
/// any backend's factorisation can drive them.

#include <functional>

#include "ecmor/export.hpp"
#include "ecmor/shifted_solver.hpp"
#include "ecmor/types.hpp"

namespace ecmor {

struct EigenOptions {
  Index nev = 6;              ///< number of eigenpairs wanted, 1 <= nev < N
  Index ncv = 0;              ///< Lanczos/Arnoldi basis size; 0: min(N, max(2 nev + 1, 20))
  double tolerance = 0.0;     ///< ARPACK's relative accuracy; 0: machine precision
  Index max_iterations = 1000;///< implicit restarts
  std::uint64_t seed = 0;     ///< 0: ARPACK's default start vector; else a seeded random one
  void validate(Index n) const;  ///< throws ConfigError naming the field
};

/// K phi = lambda M phi, K and M symmetric, M positive definite, the nev eigenvalues nearest sigma,
/// by ARPACK's dsaupd/dseupd in shift-invert mode (mode 3): OP = (K - sigma M)^-1 M, inner product M.
struct SymmetricEigenResult {
  Vector eigenvalues;   ///< lambda, ascending
  Matrix eigenvectors;  ///< N x nconv, M-orthonormal columns
  Index iterations = 0; ///< ARPACK restarts
  Index operator_applications = 0;  ///< solves with the factorisation
};

/// \param factorization  of K - sigma M (e.g. solver.factorize_combination({1, 0, -sigma}))
/// \param M              the mass matrix (inner product)
/// \throws NumericalError if ARPACK fails (reports ARPACK's info code and its meaning) or converges
///         fewer than nev eigenpairs.
ECMOR_API SymmetricEigenResult symmetric_shift_invert(const Factorization& factorization,
                                                      const SparseMatrix& M, double sigma,
                                                      const EigenOptions& options);

/// A x = lambda E x (general, E possibly singular), the nev finite eigenvalues nearest sigma, by
/// ARPACK's dnaupd/dneupd with OP = (A - sigma E)^-1 E (regular mode on the transformed operator).
/// With left = true, computes left eigenvectors y' A = lambda y' E through the transposed solves.
struct GeneralEigenResult {
  ComplexVector eigenvalues;    ///< lambda, sorted by distance to sigma
  ComplexMatrix eigenvectors;   ///< N x nconv, unit 2-norm columns
  Index iterations = 0;
  Index operator_applications = 0;
};

/// \param factorization of A - sigma E
ECMOR_API GeneralEigenResult general_shift_invert(const Factorization& factorization,
                                                  const SparseMatrix& E, double sigma,
                                                  const EigenOptions& options, bool left = false);

/// Dense reference eigen-decomposition of the pencil (for small models, tests and `ecmor info`):
/// the generalized eigenvalues of K phi = lambda M phi, ascending. N must be small (<= 5000).
ECMOR_API Vector dense_generalized_eigenvalues(const Matrix& K, const Matrix& M);

}  // namespace ecmor
