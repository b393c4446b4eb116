#include "ecmor/stability.hpp"

#include <fmt/format.h>

#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "ecmor/error.hpp"
#include "ecmor/frequency_response.hpp"
#include "ecmor/lyapunov.hpp"
#include "power_of_two_scaling.hpp"

namespace ecmor {

std::string to_string(Stability s) {
  switch (s) {
    case Stability::Asymptotic:
      return "asymptotically stable";
    case Stability::Marginal:
      return "marginally stable";
    case Stability::Unstable:
      return "unstable";
    case Stability::Unknown:
      break;
  }
  return "unknown";
}

namespace {

// A computed pole counts as on the imaginary axis when its real part is below kAxisTolerance of
// its own modulus: an undamped oscillation, whose real part rounding leaves at eps |p| of either
// sign. A pole at s = 0 cannot be told from a slow real pole by its size (descriptor models spread
// their poles over many decades: mna1 from 5.7e4 to 4.5e20, all stable), so it is found
// structurally: s = 0 is a pole exactly when A is singular. With d = n - rank(A) (rank-revealing
// QR of the equilibrated A), the d poles of least modulus, and any below kZeroTolerance of the
// largest (the second pole of a Jordan block at 0 comes out near sqrt(eps)), are poles at s = 0.
constexpr double kAxisTolerance = 1e-9;
constexpr double kZeroTolerance = 1e-6;

// Rank deficiency of A after scaling its rows and columns by powers of two (rank is invariant).
Index rank_deficiency(Matrix A) {
  const Index n = A.rows();
  if (n == 0) return 0;
  detail::scale_by_powers_of_two(A);
  Eigen::ColPivHouseholderQR<Matrix> qr(A);
  qr.setThreshold(1e3 * static_cast<double>(n) * std::numeric_limits<double>::epsilon());
  return n - qr.rank();
}

StabilityReport dense_check(const Model& model, Index states) {
  StabilityReport r;
  r.dense = true;
  r.method = fmt::format("dense eigenvalues of the {0} x {0} first-order pencil", states);
  ComplexVector p;
  Index zero_poles = 0;
  try {
    const ReducedModel dense = densify(model);
    p = poles(dense);
    zero_poles = rank_deficiency(first_order_realization(dense).A);
  } catch (const Error& e) {
    r.verdict = Stability::Unknown;
    r.reason = std::string("dense eigenvalue computation failed: ") + e.what();
    r.max_real_pole = std::numeric_limits<double>::quiet_NaN();
    return r;
  }
  double max_re = -std::numeric_limits<double>::infinity();
  Index i_max = -1;
  std::vector<double> modulus;
  for (Index i = 0; i < p.size(); ++i) {
    modulus.push_back(std::abs(p(i)));
    if (p(i).real() > max_re) {
      max_re = p(i).real();
      i_max = i;
    }
  }
  if (i_max < 0) {  // no finite pole (a purely algebraic model): nothing can grow
    r.verdict = Stability::Asymptotic;
    r.max_real_pole = -std::numeric_limits<double>::infinity();
    r.reason = "no finite pole";
    return r;
  }
  // The zero_poles poles of least modulus, and any tiny next to the largest, are at s = 0.
  std::vector<Index> order(static_cast<std::size_t>(p.size()));
  for (Index i = 0; i < p.size(); ++i) order[static_cast<std::size_t>(i)] = i;
  std::sort(order.begin(), order.end(), [&](Index a, Index b) {
    return modulus[static_cast<std::size_t>(a)] < modulus[static_cast<std::size_t>(b)];
  });
  const double largest = modulus[static_cast<std::size_t>(order.back())];
  std::vector<bool> at_zero(static_cast<std::size_t>(p.size()), false);
  for (std::size_t k = 0; k < order.size(); ++k) {
    const std::size_t i = static_cast<std::size_t>(order[k]);
    if (zero_poles > 0 && (static_cast<Index>(k) < zero_poles ||
                           modulus[i] <= kZeroTolerance * largest))
      at_zero[i] = true;
  }
  auto on_axis = [&](Index i) {
    return at_zero[static_cast<std::size_t>(i)] ||
           std::abs(p(i).real()) <= kAxisTolerance * std::abs(p(i));
  };
  r.max_real_pole = max_re;
  Index right = 0, axis = 0;
  Complex worst_right(0.0, 0.0), worst_axis(0.0, 0.0);
  for (Index i = 0; i < p.size(); ++i) {
    if (on_axis(i)) {
      if (axis++ == 0) worst_axis = p(i);
    } else if (p(i).real() > 0.0) {
      if (right++ == 0 || p(i).real() > worst_right.real()) worst_right = p(i);
    }
  }
  if (right > 0) {
    r.verdict = Stability::Unstable;
    r.reason = fmt::format("{} pole(s) in the right half-plane, the largest real part {:.4g} "
                           "(pole {:.4g}{:+.4g}i)",
                           right, worst_right.real(), worst_right.real(), worst_right.imag());
  } else if (axis > 0) {
    r.verdict = Stability::Marginal;
    r.reason = fmt::format("{} pole(s) on the imaginary axis ({} at s = 0: A has rank "
                           "deficiency {}), e.g. {:.4g}{:+.4g}i: undamped modes or rigid-body "
                           "motion",
                           axis, std::count(at_zero.begin(), at_zero.end(), true), zero_poles,
                           worst_axis.real(), worst_axis.imag());
  } else {
    r.verdict = Stability::Asymptotic;
    r.reason = fmt::format("every pole has Re < 0; the largest real part is {:.4g}", max_re);
  }
  return r;
}

StabilityReport second_order_check(const SecondOrderModel& m) {
  StabilityReport r;
  r.max_real_pole = std::numeric_limits<double>::quiet_NaN();
  r.method = "sparse Cholesky of K and D (M, D, K symmetric, M positive definite)";
  if (!(relative_asymmetry(m.K) <= 1e-10) || !(relative_asymmetry(m.D) <= 1e-10)) {
    r.verdict = Stability::Unknown;
    r.reason = "K or D is not symmetric: no structural test applies";
    return r;
  }
  if (!is_positive_definite(m.K)) {
    // Singular but semidefinite (a pole at s = 0) or indefinite (a real pole s > 0): K + sigma M
    // is positive definite for a small sigma > 0 only in the first case.
    const double sigma = 1e-8 * m.K.norm() / std::max(m.M.norm(), 1e-300);
    const SparseMatrix shifted = (m.K + sigma * m.M).pruned();
    if (is_positive_definite(shifted)) {
      r.verdict = Stability::Marginal;
      r.reason = "K is singular (positive semidefinite): a pole at s = 0 (rigid-body motion)";
    } else {
      r.verdict = Stability::Unstable;
      r.reason = "K is indefinite: a real pole s > 0 (negative stiffness, buckling)";
    }
    return r;
  }
  if (m.D.nonZeros() == 0) {
    r.verdict = Stability::Marginal;
    r.reason = "D = 0 with K positive definite: every pole on the imaginary axis (undamped)";
  } else if (is_positive_definite(m.D)) {
    r.verdict = Stability::Asymptotic;
    r.reason = "K and D positive definite: every mode is damped";
  } else {
    r.verdict = Stability::Unknown;
    r.reason = "D is not positive definite: some modes may be undamped";
  }
  return r;
}

}  // namespace

StabilityReport dense_model_stability(const Model& model) {
  const bool second = std::holds_alternative<SecondOrderModel>(model);
  return dense_check(model, second ? 2 * size_of(model) : size_of(model));
}

StabilityReport full_model_stability(const Model& model, Index dense_states) {
  const bool second = std::holds_alternative<SecondOrderModel>(model);
  const Index states = second ? 2 * size_of(model) : size_of(model);
  const bool dense_allowed = states <= std::min(dense_states, kMaxDenseStates);
  // The structural test costs two sparse Cholesky factorisations and is a theorem where it
  // decides; the dense eigenvalues (cubic in the states: 3 s at 902) only where it cannot.
  if (second) {
    StabilityReport r = second_order_check(std::get<SecondOrderModel>(model));
    if (r.verdict != Stability::Unknown || !dense_allowed) return r;
  }
  if (dense_allowed) return dense_check(model, states);
  StabilityReport r;
  r.max_real_pole = std::numeric_limits<double>::quiet_NaN();
  r.method = "none";
  r.reason = fmt::format("a descriptor model with {} states, above the dense limit {}", states,
                         dense_states);
  return r;
}

}  // namespace ecmor
