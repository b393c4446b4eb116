// spectrum_slicer.cpp: the slices of SymmetricSlicer (spectrum_slicer.hpp).
#include "ecmor/linalg/spectrum_slicer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "ecmor/base/error.hpp"
#include "ecmor/linalg/eigensolver.hpp"

namespace ecmor {

namespace {

/// Ritz values farther than this factor times the nearest eigenvalue's distance from the shift are
/// not trusted: shift-invert computes nu = 1/(lambda - sigma) with absolute error ~eps |nu_max|, so
/// lambda - sigma has relative error ~eps * ratio; 1e4 keeps it near 1e-12.
constexpr double kTrustRatio = 1e4;

}  // namespace

SymmetricSlicer::SymmetricSlicer(const SparseMatrix& Ks, const SparseMatrix& Ms,
                                 ShiftedSolver& solver, FactorizeFn factorize, bool second_order,
                                 const SliceOptions& options, double f_min_hz, RigidBodyModes rigid)
    : m_K(Ks),
      m_M(Ms),
      m_solver(solver),
      m_factorize(std::move(factorize)),
      m_second_order(second_order),
      m_options(options),
      m_n(Ks.rows()),
      m_rigid(std::move(rigid)) {
  m_scale = spectrum_scale(Ks, Ms);
  m_k_norm = Ks.norm();
  m_phi.resize(m_n, 0);
  const double omega_min = kTwoPi * f_min_hz;
  // sigma_0 < 0 so that K - sigma_0 M is SPD even for singular K (Cholesky applies); not so close
  // to 0 that it is numerically singular for a free-floating body.
  const double band_value = m_second_order ? omega_min * omega_min : omega_min;
  m_sigma0 = -std::max(band_value, 1e-6 * m_scale);
  // The rigid-body modes are part of the basis exactly as the null-space analysis found them
  // (M-orthonormal); the slices then find them again and drop them as copies.
  for (Index j = 0; j < m_rigid.count; ++j) add(0.0, m_rigid.basis.col(j));
}

void SymmetricSlicer::next_batch() {
  if (complete()) return;
  double delta = m_delta;
  for (int attempt = 0; attempt < 8; ++attempt) {
    const double sigma = m_batches == 0 ? m_sigma0 : m_lambda_cov + delta;
    std::shared_ptr<const Factorization> F;
    const Index failed_before = m_solver.counters().failed_cholesky;
    try {
      F = m_factorize(sigma);
    } catch (const NumericalError&) {
      if (m_batches == 0) throw;
      delta *= 0.7;  // sigma hit an eigenvalue: move off it
      continue;
    }
    EigenOptions eo;
    eo.nev = std::min<Index>(m_options.batch_size, m_n - 1);
    eo.tolerance = m_options.tolerance;
    eo.max_iterations = m_options.max_iterations;
    eo.seed = m_options.seed;
    const SymmetricEigenResult r = symmetric_shift_invert(*F, m_M, sigma, eo);
    m_applications += r.operator_applications;
    m_eigensolver = r.method;
    if (r.eigenvalues.size() == 0) {
      throw NumericalError(
          fmt::format("{}: ARPACK returned no eigenpair at shift {:g}", m_options.caller, sigma));
    }
    const Vector dist = (r.eigenvalues.array() - sigma).abs();
    const double d_near = dist.minCoeff();
    const double r_max = dist.maxCoeff();
    const double t = std::min(r_max, kTrustRatio * std::max(d_near, 1e-300));
    if (m_batches > 0 && sigma - t > m_lambda_cov * (1.0 + 1e-12) + 1e-300) {
      delta *= 0.25;  // the slice does not reach back to the frontier: a gap; retry nearer
      continue;
    }
    // Indefinite Ks: an eigenvalue clearly below 0, or (whatever ARPACK found) a failed
    // Cholesky of Ks - sigma_0 Ms, which is SPD whenever Ks is positive semidefinite. Either
    // breaks the premise that sigma_0 lies below the whole spectrum.
    const bool cholesky_failed =
        m_batches == 0 && m_solver.counters().failed_cholesky > failed_before;
    if (r.eigenvalues.minCoeff() < -rigid_threshold() || cholesky_failed) {
      throw InputError(fmt::format(
          "{}: {} has a negative eigenvalue ({}): it must be positive semidefinite for "
          "modal truncation",
          m_options.caller, m_second_order ? "K" : "-A",
          cholesky_failed
              ? fmt::format("the Cholesky factorisation of {} - sigma M failed at "
                            "sigma = {:g} < 0",
                            m_second_order ? "K" : "-A", sigma)
              : fmt::format("{:g}, spectrum scale {:g}", r.eigenvalues.minCoeff(), m_scale)));
    }
    m_factorizations.push_back(F);
    m_shifts.push_back(sigma);
    const Index known_before = known();
    for (Index j = 0; j < r.eigenvalues.size(); ++j) {
      if (dist[j] <= t) add(r.eigenvalues[j], r.eigenvectors.col(j));
    }
    m_empty_batches = known() > known_before ? 0 : m_empty_batches + 1;
    // Covered now: every eigenvalue in [sigma - t, sigma + t].
    m_lambda_cov = m_batches == 0 ? sigma + t : std::max(m_lambda_cov, sigma + t);
    ++m_batches;
    // Next step: place the shift so that about 80 % of the next batch is new, from the density of
    // eigenvalues just seen; the gap check above repairs an over-long step.
    const Index found = r.eigenvalues.size();
    const double width = r.eigenvalues.maxCoeff() - std::max(r.eigenvalues.minCoeff(), 0.0);
    if (found >= 2 && width > 0.0) {
      const double density = static_cast<double>(found - 1) / width;
      m_delta = 0.6 * static_cast<double>(eo.nev) / (2.0 * density);
    } else {
      m_delta = std::max(std::abs(m_lambda_cov - sigma), 1e-3 * m_scale);
    }
    return;
  }
  throw NumericalError(fmt::format(
      "{}: spectrum slicing could not place a shift above lambda = {:g} without leaving a gap "
      "(8 attempts); increase batch_size",
      m_options.caller, m_lambda_cov));
}

void SymmetricSlicer::add(double lambda, const Vector& phi_in) {
  Vector phi = phi_in;
  // A Ritz pair that is not an eigenpair (ARPACK past the top of the spectrum, or mixing the
  // copies of a multiple eigenvalue) is dropped: relative residual above the admissible one.
  const double residual = (m_K * phi - lambda * (m_M * phi)).norm() /
                          (std::max(m_k_norm, 1e-300) * std::max(phi.norm(), 1e-300));
  if (!(residual <= std::max(1e-6, 100.0 * m_options.tolerance))) {
    ++m_spurious;
    return;
  }
  const double tol = 1e-8 * std::max(std::abs(lambda), rigid_threshold());
  // All rigid-body modes share the eigenvalue 0: a computed one is a copy when it lies in their
  // span, whatever its rounding-level eigenvalue.
  const bool rigid = is_rigid(lambda);
  std::vector<Index> same;
  for (Index j = 0; j < known(); ++j) {
    const double lj = m_lambda[static_cast<std::size_t>(j)];
    if (rigid ? is_rigid(lj) : std::abs(lj - lambda) <= tol) same.push_back(j);
  }
  if (!same.empty()) {
    for (int pass = 0; pass < 2; ++pass) {
      for (Index j : same) {
        const double c = m_phi.col(j).dot(m_M * phi);
        phi -= c * m_phi.col(j);
      }
    }
    const double norm = std::sqrt(phi.dot(m_M * phi));
    if (norm <= 1e-6) {
      ++m_duplicates;
      return;
    }
    phi /= norm;
  }
  if (complete()) return;
  m_lambda.push_back(lambda);
  m_phi.conservativeResize(Eigen::NoChange, m_phi.cols() + 1);
  m_phi.col(m_phi.cols() - 1) = phi;
}

SymmetricSlicer::FactorizeFn pencil_factorizer(ShiftedSolver& solver, bool second_order) {
  ShiftedSolver* s = &solver;
  if (second_order) {
    return [s](double sigma) {
      const Complex w[3] = {1.0, 0.0, -sigma};
      return s->factorize_combination(w);
    };
  }
  return [s](double sigma) {
    const Complex w[2] = {1.0, -sigma};
    return s->factorize_combination(w);
  };
}

}  // namespace ecmor
