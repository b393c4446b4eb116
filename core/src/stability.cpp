#include "ecmor/stability.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "ecmor/error.hpp"
#include "ecmor/frequency_response.hpp"
#include "ecmor/lyapunov.hpp"

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

// Relative size below which a real part counts as zero: eigenvalues of an undamped or
// free-floating model come out with real parts of order N eps max|p|, of either sign.
constexpr double kAxisTolerance = 1e-9;

StabilityReport dense_check(const Model& model, Index states) {
  StabilityReport r;
  r.dense = true;
  r.method = fmt::format("dense eigenvalues of the {0} x {0} first-order pencil", states);
  ComplexVector p;
  try {
    p = poles(densify(model));
  } catch (const Error& e) {
    r.verdict = Stability::Unknown;
    r.reason = std::string("dense eigenvalue computation failed: ") + e.what();
    r.max_real_pole = std::numeric_limits<double>::quiet_NaN();
    return r;
  }
  double scale = 0.0, max_re = -std::numeric_limits<double>::infinity();
  Index i_max = -1;
  for (Index i = 0; i < p.size(); ++i) {
    scale = std::max(scale, std::abs(p(i)));
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
  r.max_real_pole = max_re;
  const double axis = kAxisTolerance * std::max(1.0, scale);
  Index right = 0, on_axis = 0;
  for (Index i = 0; i < p.size(); ++i) {
    if (p(i).real() > axis)
      ++right;
    else if (p(i).real() >= -axis)
      ++on_axis;
  }
  const Complex worst = p(i_max);
  if (right > 0) {
    r.verdict = Stability::Unstable;
    r.reason = fmt::format("{} pole(s) in the right half-plane, the largest real part {:.4g} "
                           "(pole {:.4g}{:+.4g}i)",
                           right, max_re, worst.real(), worst.imag());
  } else if (on_axis > 0) {
    r.verdict = Stability::Marginal;
    r.reason = fmt::format("{} pole(s) on the imaginary axis (|Re p| <= {:.1e} max|p|), e.g. "
                           "{:.4g}{:+.4g}i: undamped modes or rigid-body motion",
                           on_axis, kAxisTolerance, worst.real(), worst.imag());
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

StabilityReport full_model_stability(const Model& model, Index dense_states) {
  const bool second = std::holds_alternative<SecondOrderModel>(model);
  const Index states = second ? 2 * size_of(model) : size_of(model);
  if (states <= std::min(dense_states, kMaxDenseStates)) return dense_check(model, states);
  if (second) return second_order_check(std::get<SecondOrderModel>(model));
  StabilityReport r;
  r.max_real_pole = std::numeric_limits<double>::quiet_NaN();
  r.method = "none";
  r.reason = fmt::format("a descriptor model with {} states, above the dense limit {}", states,
                         dense_states);
  return r;
}

}  // namespace ecmor
