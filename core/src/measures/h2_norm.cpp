// h2_norm.cpp: H2 norms of dense models by Gramians, and of large full models by adaptive
// Gauss-Kronrod quadrature of the frequency response.
#include "ecmor/measures/h2_norm.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <variant>

#include "base/number_text.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/options.hpp"
#include "ecmor/gramians/lyapunov.hpp"
#include "ecmor/gramians/quadrature.hpp"
#include "ecmor/model/dense_model.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/response/reduced_response.hpp"
#include "linalg/gauss_kronrod.hpp"
#include "model/model_checks.hpp"

namespace ecmor {
using detail::kNodes;
using detail::nodes_of;
using detail::Piece;
using detail::require_same_io;
using detail::rule;

namespace {

/// The pieces of ||Ga - Gb||^2 = na + nb - 2 <Ga, Gb> that a caller needs.
struct H2Parts {
  double na = 0.0, nb = 0.0, cross = 0.0;
};

H2Parts h2_parts(const ReducedModel& a, const ReducedModel& b, std::string_view origin,
                 bool norms) {
  require_same_io(a, b, origin);
  const SchurPencil pa = stable_pencil(a, origin);
  const SchurPencil pb = stable_pencil(b, origin);
  const ReducedDescriptorModel ra = first_order_realization(a);
  const ReducedDescriptorModel rb = first_order_realization(b);
  H2Parts parts;
  parts.cross = sylvester_trace(pa, pb, ra.B, rb.B, ra.C, rb.C);
  if (norms) {
    parts.na = sylvester_trace(pa, pa, ra.B, ra.B, ra.C, ra.C);
    parts.nb = sylvester_trace(pb, pb, rb.B, rb.B, rb.C, rb.C);
  }
  return parts;
}

/// Geometric mean of the positive finite values (0 if none).
double geometric_mean(const std::vector<double>& v) {
  double s = 0.0;
  Index k = 0;
  for (double x : v)
    if (x > 0.0 && std::isfinite(x)) {
      s += std::log(x);
      ++k;
    }
  return k > 0 ? std::exp(s / static_cast<double>(k)) : 0.0;
}

/// A cheap scale of the full model's pole magnitudes: the geometric mean over rows i of
/// ||A_i,:|| / ||E_i,:|| (descriptor) or sqrt(||K_i,:|| / ||M_i,:||) (second order). For a
/// first-order model in x = [q; q'] (build, iss) the rows give 1 and about omega_i^2 alike, so the
/// mean is still a typical omega_i; the diagonal alone would give damping rates instead.
double full_model_scale(const Model& full) {
  const auto row_norms = [](const SparseMatrix& X) {
    Vector r = Vector::Zero(X.rows());
    for (Index j = 0; j < X.outerSize(); ++j)
      for (SparseMatrix::InnerIterator it(X, j); it; ++it) r(it.row()) += it.value() * it.value();
    return Vector(r.cwiseSqrt());
  };
  std::vector<double> ratios;
  if (const auto* s = std::get_if<SecondOrderModel>(&full)) {
    const Vector k = row_norms(s->K), m = row_norms(s->M);
    for (Index i = 0; i < k.size(); ++i)
      if (m(i) > 0.0) ratios.push_back(std::sqrt(k(i) / m(i)));
  } else {
    const auto& d = std::get<DescriptorModel>(full);
    const Vector a = row_norms(d.A), e = row_norms(d.E);
    for (Index i = 0; i < a.size(); ++i)
      if (e(i) > 0.0) ratios.push_back(a(i) / e(i));
  }
  const double g = geometric_mean(ratios);
  return g > 0.0 ? g : 1.0;
}

}  // namespace

double h2_norm(const ReducedModel& model) {
  const SchurPencil pencil = stable_pencil(model, "h2_norm");
  const ReducedDescriptorModel r = first_order_realization(model);
  return std::sqrt(std::max(0.0, sylvester_trace(pencil, pencil, r.B, r.B, r.C, r.C)));
}

double h2_error_norm(const ReducedModel& a, const ReducedModel& b) {
  const H2Parts p = h2_parts(a, b, "h2_error_norm", true);
  // The three terms are of size ||G||^2; their sum can be a rounding error below zero when the
  // models agree to ~1e-8.
  return std::sqrt(std::max(0.0, p.na + p.nb - 2.0 * p.cross));
}

H2Comparison h2_compare(const ReducedModel& a, const ReducedModel& b) {
  const H2Parts p = h2_parts(a, b, "h2_compare", true);
  H2Comparison c;
  c.norm_a = std::sqrt(std::max(0.0, p.na));
  c.norm_b = std::sqrt(std::max(0.0, p.nb));
  c.error = std::sqrt(std::max(0.0, p.na + p.nb - 2.0 * p.cross));
  return c;
}

double h2_inner_product(const ReducedModel& a, const ReducedModel& b) {
  return h2_parts(a, b, "h2_inner_product", false).cross;
}

void H2QuadratureOptions::validate() const {
  const auto bad = [](const std::string& field, double value, const std::string& rule) {
    throw ConfigError("H2QuadratureOptions: " + field + " = " + detail::number_text(value) + ": " +
                      rule);
  };
  // The adaptive quadrature's own fields obey its rules.
  AdaptiveQuadratureOptions adaptive;
  adaptive.relative_tolerance = relative_tolerance;
  adaptive.absolute_tolerance = absolute_tolerance;
  adaptive.max_evaluations = max_evaluations;
  adaptive.initial_intervals = initial_intervals;
  AdaptiveQuadratureOptions::specs().validate(adaptive, "H2QuadratureOptions");
  if (!(scale_rad_s >= 0.0 && std::isfinite(scale_rad_s)))
    bad("scale_rad_s", scale_rad_s, "must be finite and >= 0 (0: automatic)");
  for (double w : breakpoints_rad_s)
    if (!(w > 0.0 && std::isfinite(w)))
      bad("breakpoints_rad_s", w, "every breakpoint must be finite and > 0");
  if (band) band->validate();
}

H2Result h2_error_quadrature(const Model& full, ShiftedSolver& solver, const ReducedModel* reduced,
                             const H2QuadratureOptions& options) {
  options.validate();
  constexpr double kHalfPi = 0.5 * kPi;
  std::vector<double> pole_omegas;  // |Im lambda| of the reduced poles, least damped first
  std::optional<ReducedResponse> response;
  double w0 = options.scale_rad_s;
  if (reduced != nullptr) {
    validate(*reduced, "h2_error_quadrature: reduced model");
    if (inputs_of(*reduced) != inputs_of(full) || outputs_of(*reduced) != outputs_of(full))
      throw InputError("h2_error_quadrature: the reduced model has a " +
                       std::to_string(outputs_of(*reduced)) + " x " +
                       std::to_string(inputs_of(*reduced)) + " transfer matrix, the full model " +
                       std::to_string(outputs_of(full)) + " x " + std::to_string(inputs_of(full)) +
                       " (outputs x inputs): they must be equal");
    const SchurPencil pencil = stable_pencil(*reduced, "h2_error_quadrature: reduced model");
    const ComplexVector& lambda = pencil.eigenvalues();
    std::vector<std::pair<double, double>> by_damping;  // (damping ratio, |Im|)
    std::vector<double> magnitudes;
    for (const Complex& z : lambda) {
      magnitudes.push_back(std::abs(z));
      if (z.imag() > 0.0) by_damping.emplace_back(-z.real() / std::abs(z), z.imag());
    }
    std::sort(by_damping.begin(), by_damping.end());
    for (const auto& [zeta, w] : by_damping) pole_omegas.push_back(w);
    if (w0 == 0.0) w0 = geometric_mean(magnitudes);
    response.emplace(*reduced);
  }
  if (w0 == 0.0) w0 = full_model_scale(full);

  // Initial partition of theta: equal pieces, then breakpoints at the images of the poles (least
  // damped first, as long as they leave half the budget to refinement) and the user's.
  // A band restricts theta to the images of its ends.
  const double theta_lo = options.band ? std::atan(kTwoPi * options.band->f_min_hz / w0) : 0.0;
  const double theta_hi = options.band ? std::atan(kTwoPi * options.band->f_max_hz / w0) : kHalfPi;
  std::vector<double> cuts;
  for (Index i = 0; i <= options.initial_intervals; ++i)
    cuts.push_back(theta_lo + (theta_hi - theta_lo) * static_cast<double>(i) /
                                  static_cast<double>(options.initial_intervals));
  cuts.back() = theta_hi;
  const auto add_cut = [&](double w) {
    const double theta = std::atan(w / w0);
    if (theta > theta_lo && theta < theta_hi) cuts.push_back(theta);
  };
  for (double w : options.breakpoints_rad_s) add_cut(w);
  const Index pole_room =
      std::max<Index>(0, options.max_evaluations / (2 * kNodes) - static_cast<Index>(cuts.size()));
  for (std::size_t i = 0; i < pole_omegas.size() && static_cast<Index>(i) < pole_room; ++i)
    add_cut(pole_omegas[i]);
  std::sort(cuts.begin(), cuts.end());
  std::vector<double> unique_cuts;
  for (double c : cuts)
    if (unique_cuts.empty() || c - unique_cuts.back() > 1e-12) unique_cuts.push_back(c);
  unique_cuts.back() = theta_hi;

  H2Result result;
  result.scale_rad_s = w0;
  const double inv_two_pi = 1.0 / kTwoPi;

  // Evaluates the rule on each interval: all nodes of all intervals in one parallel call.
  auto evaluate = [&](std::vector<Piece>& batch) {
    std::vector<double> theta(batch.size() * kNodes), f_hz(theta.size());
    for (std::size_t i = 0; i < batch.size(); ++i)
      nodes_of(batch[i].a, batch[i].b, &theta[i * kNodes]);
    for (std::size_t i = 0; i < theta.size(); ++i) f_hz[i] = w0 * std::tan(theta[i]) * inv_two_pi;
    const std::vector<ComplexMatrix> H = frequency_response(full, solver, f_hz, options.threads);
    std::vector<double> values(theta.size());
    for (std::size_t i = 0; i < theta.size(); ++i) {
      double e2 = 0.0;
      if (response) {
        e2 = (H[i] - (*response)(s_from_hz(f_hz[i]))).squaredNorm();
      } else {
        e2 = H[i].squaredNorm();
      }
      // d omega / d theta = w0 (1 + tan^2) = w0 + omega^2 / w0, bounded times ||G||^2 ~ 1/omega^2.
      const double omega = kTwoPi * f_hz[i];
      values[i] = e2 * (w0 + omega * (omega / w0)) / kPi;
    }
    for (std::size_t i = 0; i < batch.size(); ++i) rule(batch[i], &values[i * kNodes]);
    result.evaluations += static_cast<Index>(theta.size());
  };

  std::vector<Piece> pieces;
  for (std::size_t i = 0; i + 1 < unique_cuts.size(); ++i)
    pieces.push_back(Piece{unique_cuts[i], unique_cuts[i + 1]});
  evaluate(pieces);

  while (true) {
    double integral = 0.0, error = 0.0;
    for (const Piece& p : pieces) {
      integral += p.kronrod;
      error += p.error;
    }
    result.integral = integral;
    result.integral_error = error;
    const detail::Round round = detail::adaptive_round(
        pieces, error, std::abs(integral), options.relative_tolerance, options.absolute_tolerance,
        options.max_evaluations - result.evaluations, evaluate);
    result.converged = round == detail::Round::Converged;
    if (round != detail::Round::Refined) break;
  }
  result.intervals = static_cast<Index>(pieces.size());
  result.value = std::sqrt(std::max(0.0, result.integral));
  result.error_estimate = result.value > 0.0 ? result.integral_error / (2.0 * result.value)
                                             : std::sqrt(result.integral_error);
  result.method =
      std::string(options.band ? "band " : "") +
      "adaptive Gauss-Kronrod 7/15 on omega = w0 tan(theta), w0 = " + detail::number_text(w0) +
      " rad/s, " + std::to_string(unique_cuts.size() - 1) + " initial intervals (" +
      std::to_string(
          reduced ? std::min<std::size_t>(pole_omegas.size(), static_cast<std::size_t>(pole_room))
                  : 0) +
      " pole breakpoints), " + std::to_string(result.intervals) + " final intervals";
  return result;
}

}  // namespace ecmor
