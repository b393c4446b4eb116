#pragma once
/// \file spectrum_slicer.hpp
/// The lowest eigenpairs of a symmetric pencil, computed in slices by shift-invert Lanczos and
/// certified contiguous: every eigenvalue below the frontier is known, none is skipped. The modal
/// reducer builds its bases from it and `ecmor info` lists eigenfrequencies with it, so both
/// call the same modes rigid (rigid_body.hpp).

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "ecmor/base/types.hpp"
#include "ecmor/export.hpp"
#include "ecmor/linalg/rigid_body.hpp"
#include "ecmor/linalg/shifted_solver.hpp"

namespace ecmor {

/// The eigensolver settings of one slice.
struct SliceOptions {
  Index batch_size = 20;        ///< eigenpairs per ARPACK run (one slice), >= 1
  double tolerance = 0.0;       ///< ARPACK's relative accuracy of the Ritz values; 0 = eps
  Index max_iterations = 1000;  ///< ARPACK implicit restarts per run
  std::uint64_t seed = 1;       ///< seed of ARPACK's start vectors
  std::string caller = "spectrum slicing";  ///< names the caller at the start of error messages
};

/// Symmetric pencil  Ks phi = lambda Ms phi, Ms SPD, Ks positive semidefinite, solved in slices.
/// Second order: Ks = K, Ms = M, f = sqrt(lambda) / 2pi. Symmetric descriptor: Ks = -A, Ms = E,
/// poles -lambda, f = lambda / 2pi.
///
/// Why the covered interval is contiguous: a converged ARPACK run at shift sigma returns the nev
/// eigenvalues nearest sigma, i.e. every eigenvalue in [sigma - r, sigma + r] with r the largest
/// returned distance (we keep only the trusted part [sigma - t, sigma + t], t <= r, which is again
/// "every eigenvalue in an interval"). The first shift sigma_0 < 0 lies below the whole spectrum
/// (Ks positive semidefinite, checked on the results), so it covers (-inf, sigma_0 + t]. A later
/// shift sigma = lambda_cov + delta is accepted only if sigma - t <= lambda_cov, so the union of
/// covered intervals stays one interval (-inf, lambda_cov]; otherwise delta shrinks and the batch
/// is redone. Hence every eigenvalue below the frontier is known and none is skipped. (Caveat of
/// any single-vector Lanczos method: copies of an exactly multiple eigenvalue are found through
/// rounding; the deduplication below keeps every genuinely new copy.)
class ECMOR_API SymmetricSlicer {
 public:
  using FactorizeFn = std::function<std::shared_ptr<const Factorization>(double sigma)>;

  /// \param f_min_hz the lowest frequency of interest: sigma_0 = -max(omega_min^2 (second order)
  ///                 or omega_min, 1e-6 * spectrum scale).
  /// \param solver  factorises Ks - sigma Ms (factorize); its failed-Cholesky counter tells whether
  ///                 Ks - sigma_0 Ms is indefinite, i.e. Ks is not positive semidefinite.
  /// \param rigid   the rigid-body modes of (Ks, Ms) (rigid_body_modes): they enter first, with
  ///                 eigenvalue 0, and a computed eigenvalue is rigid when |lambda| <= zero_bound.
  SymmetricSlicer(const SparseMatrix& Ks, const SparseMatrix& Ms, ShiftedSolver& solver,
                  FactorizeFn factorize, bool second_order, const SliceOptions& options,
                  double f_min_hz, RigidBodyModes rigid);

  Index size() const { return m_n; }
  Index known() const { return static_cast<Index>(m_lambda.size()); }
  /// Every eigenpair is known, or the slicing is exhausted: kMaxEmptyBatches batches in a row
  /// added nothing (the shift is above the spectrum, or ARPACK misses the copies of a multiple
  /// eigenvalue), so more slices would only climb without end.
  bool complete() const { return known() >= m_n || m_empty_batches >= kMaxEmptyBatches; }
  bool exhausted() const { return known() < m_n && m_empty_batches >= kMaxEmptyBatches; }
  Index spurious() const { return m_spurious; }
  /// |lambda| below which a computed eigenvalue is 0: the rigid-body analysis's bound (the
  /// geometric mean across the gap between rigid and elastic eigenvalues) when K is singular, else
  /// the rounding floor (nothing is rigid then).
  double rigid_threshold() const {
    return m_rigid.count > 0 ? m_rigid.zero_bound : kRigidFloor * m_scale;
  }
  bool is_rigid(double lambda) const {
    return m_rigid.count > 0 && std::abs(lambda) <= m_rigid.zero_bound;
  }
  const RigidBodyModes& rigid() const { return m_rigid; }
  double frequency(double lambda) const {
    const double l = std::max(lambda, 0.0);
    return (m_second_order ? std::sqrt(l) : l) / kTwoPi;
  }
  double frontier_frequency() const {
    if (complete()) return std::numeric_limits<double>::infinity();
    if (m_batches == 0) return -std::numeric_limits<double>::infinity();
    return frequency(m_lambda_cov);
  }
  double lambda(Index j) const { return m_lambda[static_cast<std::size_t>(j)]; }
  const Matrix& vectors() const { return m_phi; }
  double sigma0() const { return m_sigma0; }
  Index batches() const { return m_batches; }
  Index operator_applications() const { return m_applications; }
  /// The eigensolver of the last slice ("arpack", "dense" or "slepc").
  const std::string& eigensolver() const { return m_eigensolver; }
  Index duplicates() const { return m_duplicates; }
  const std::vector<double>& shifts() const { return m_shifts; }
  /// The factorisation at sigma_0 (exists after the first batch).
  const Factorization& first_factorization() const { return *m_factorizations.front(); }

  /// Computes one more slice above the frontier (or the first slice).
  /// \throws InputError when Ks is indefinite; NumericalError when ARPACK returns nothing or no
  /// shift can be placed without a gap.
  void next_batch();

 private:
  /// Adds an eigenpair unless it is already known: same eigenvalue (relative 1e-8) and inside
  /// the span of the known vectors of that eigenvalue (M inner product). A new copy of a multiple
  /// eigenvalue is M-orthogonalised against the known copies.
  void add(double lambda, const Vector& phi_in);

  static constexpr Index kMaxEmptyBatches = 3;
  const SparseMatrix& m_K;
  const SparseMatrix& m_M;
  double m_k_norm = 1.0;
  Index m_empty_batches = 0;
  Index m_spurious = 0;
  ShiftedSolver& m_solver;
  FactorizeFn m_factorize;
  bool m_second_order;
  SliceOptions m_options;
  Index m_n;
  RigidBodyModes m_rigid;
  double m_scale = 1.0;
  double m_sigma0 = -1.0;
  double m_lambda_cov = -std::numeric_limits<double>::infinity();
  double m_delta = 0.0;
  Index m_batches = 0;
  Index m_applications = 0;
  std::string m_eigensolver = "arpack";
  Index m_duplicates = 0;
  std::vector<double> m_lambda;
  Matrix m_phi;
  std::vector<double> m_shifts;
  std::vector<std::shared_ptr<const Factorization>> m_factorizations;
};

/// Factorisations of Ks - sigma Ms by `solver` (which must outlive the function): the combination
/// K - sigma M of a second-order model, -A - sigma E of a descriptor model (Ks = -A).
ECMOR_API SymmetricSlicer::FactorizeFn pencil_factorizer(ShiftedSolver& solver, bool second_order);

}  // namespace ecmor
