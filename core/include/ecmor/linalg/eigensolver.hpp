#pragma once
/// \file eigensolver.hpp
/// Shift-invert eigensolvers (ARPACK-ng) on top of a Factorization from the ShiftedSolver, so that
/// any backend's factorisation can drive them.
///
/// ARPACK keeps internal (Fortran SAVE) state between reverse-communication calls, so one run at a
/// time is allowed per process: the functions below serialise themselves with a mutex and may be
/// called from several threads (they then run one after another).
///
/// Tiny problems: ARPACK needs nev < ncv <= N (symmetric) and nev + 2 <= ncv <= N (general). For
/// N <= kDenseEigenThreshold, or when nev leaves no room for a Krylov space (nev >= N - 1), both
/// functions fall back to a dense eigensolver on the same shift-inverted operator (N solves with
/// the factorisation, then a dense symmetric resp. real nonsymmetric eigensolver), so the results
/// have the same meaning and the same accuracy profile (best near sigma) as the ARPACK path.

#include <cstdint>
#include <functional>
#include <string>

#include "ecmor/base/types.hpp"
#include "ecmor/export.hpp"
#include "ecmor/linalg/shifted_solver.hpp"

namespace ecmor {

/// Problems of at most this dimension are solved by the dense fallback (see the file comment).
constexpr Index kDenseEigenThreshold = 30;

struct ECMOR_API EigenOptions {
  Index nev = 6;  ///< number of eigenpairs wanted, 1 <= nev < N
  Index ncv = 0;  ///< Lanczos/Arnoldi basis size, nev < ncv <= N; 0: min(N, max(2 nev + 1, 20))
  double tolerance =
      0.0;  ///< ARPACK's relative accuracy of the Ritz values, >= 0; 0: machine precision
  Index max_iterations = 1000;  ///< implicit restarts, >= 1
  std::uint64_t seed = 0;       ///< 0: ARPACK's default start vector; else a seeded random one
  /// \throws ConfigError naming the field, its value and the rule, e.g.
  ///         "EigenOptions::ncv = 4: must be in (nev, N] = (6, 18]".
  void validate(Index n) const;
};

/// K phi = lambda M phi, K and M symmetric, M positive definite, the nev eigenvalues nearest sigma,
/// by ARPACK's dsaupd/dseupd in shift-invert mode (mode 3): OP = (K - sigma M)^-1 M, inner product
/// M. A factorisation of the PETSc backend (method() "mumps") in a build with SLEPc goes to SLEPc's
/// Krylov-Schur instead, on the same operator and inner product (see docs/cluster.md).
struct SymmetricEigenResult {
  Vector eigenvalues;               ///< lambda, ascending
  Matrix eigenvectors;              ///< N x nconv, M-orthonormal columns
  Index iterations = 0;             ///< ARPACK restarts (0 for the dense fallback)
  Index operator_applications = 0;  ///< solves with the factorisation (right-hand-side columns)
  bool dense_fallback = false;      ///< solved by the dense fallback (tiny problem)
  /// "arpack", "dense" (the fallback) or "slepc" (Krylov-Schur, for a factorisation of the
  /// distributed PETSc backend: the vectors stay distributed during the iteration).
  std::string method = "arpack";
};

/// \param factorization  of K - sigma M (e.g. solver.factorize_combination({1, 0, -sigma}))
/// \param M              the mass matrix (inner product)
/// \throws ConfigError for invalid options; InputError if the sizes of the factorisation and M
///         differ or the factorisation is complex; NumericalError if ARPACK fails (reports ARPACK's
///         info code and its meaning) or converges fewer than nev eigenpairs.
ECMOR_API SymmetricEigenResult symmetric_shift_invert(const Factorization& factorization,
                                                      const SparseMatrix& M, double sigma,
                                                      const EigenOptions& options);

/// A x = lambda E x (general, E possibly singular), the nev finite eigenvalues nearest sigma, by
/// ARPACK's dnaupd/dneupd with OP = (A - sigma E)^-1 E (regular mode on the transformed operator):
/// OP x = nu x  <=>  A x = (sigma + 1/nu) E x. Infinite eigenvalues (nu = 0, singular E) are never
/// returned. With left = true, computes left eigenvectors y' A = lambda y' E through the transposed
/// solves y -> (A' - sigma E')^-1 E' y.
/// A complex conjugate pair is never split: the result may hold nev + 1 eigenpairs.
struct GeneralEigenResult {
  ComplexVector eigenvalues;   ///< lambda, sorted by distance to sigma (conjugate pairs adjacent)
  ComplexMatrix eigenvectors;  ///< N x nconv, unit 2-norm columns
  Index iterations = 0;
  Index operator_applications = 0;
  bool dense_fallback = false;  ///< solved by the dense fallback (tiny problem)
};

/// \param factorization of A - sigma E
/// \throws as symmetric_shift_invert.
ECMOR_API GeneralEigenResult general_shift_invert(const Factorization& factorization,
                                                  const SparseMatrix& E, double sigma,
                                                  const EigenOptions& options, bool left = false);

/// Dense reference eigen-decomposition of the pencil (for small models, tests and `ecmor info`):
/// the generalized eigenvalues of K phi = lambda M phi, ascending. N must be small (<= 5000).
/// Symmetric K, M with M positive definite: Eigen's GeneralizedSelfAdjointEigenSolver; otherwise
/// the QZ-based GeneralizedEigenSolver, which must find only real, finite eigenvalues.
/// \throws InputError for non-square or mismatched sizes or N > 5000; NumericalError when the
///         nonsymmetric pencil has complex or infinite eigenvalues.
ECMOR_API Vector dense_generalized_eigenvalues(const Matrix& K, const Matrix& M);

}  // namespace ecmor
