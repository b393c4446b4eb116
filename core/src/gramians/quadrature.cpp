// quadrature.cpp: adaptive Gauss-Kronrod for matrix-valued integrands, and the band integrals of
// a model's resolvent (see quadrature.hpp).
#include "ecmor/gramians/quadrature.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <string>

#include "base/number_text.hpp"
#include "base/parallel_for.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/options.hpp"
#include "ecmor/response/reduced_response.hpp"
#include "linalg/gauss_kronrod.hpp"

namespace ecmor {
namespace {

using detail::kNodes;

struct MatrixPiece {
  double a = 0.0, b = 0.0;
  Matrix kronrod;
  double error = 0.0;
  bool splittable = true;
};

/// The Kronrod sum and the error estimate of one interval from f at nodes_of(a, b).
void matrix_rule(MatrixPiece& p, const Matrix* f) {
  const double h = 0.5 * (p.b - p.a);
  Matrix k = detail::kWgk[7] * f[0];
  Matrix g = detail::kWg[3] * f[0];
  double k_abs = detail::kWgk[7] * f[0].norm();
  for (int j = 0; j < 7; ++j) {
    const Matrix pair = f[1 + 2 * j] + f[2 + 2 * j];
    k += detail::kWgk[j] * pair;
    k_abs += detail::kWgk[j] * (f[1 + 2 * j].norm() + f[2 + 2 * j].norm());
    if (j % 2 == 1) g += detail::kWg[j / 2] * pair;
  }
  const Matrix mean = 0.5 * k;
  double asc = detail::kWgk[7] * (f[0] - mean).norm();
  for (int j = 0; j < 7; ++j)
    asc += detail::kWgk[j] * ((f[1 + 2 * j] - mean).norm() + (f[2 + 2 * j] - mean).norm());
  p.kronrod = h * k;
  const double resasc = h * asc, resabs = h * k_abs;
  double err = h * (k - g).norm();
  if (resasc != 0.0 && err != 0.0)
    err = resasc * std::min(1.0, std::pow(200.0 * err / resasc, 1.5));
  p.error = std::max(50.0 * std::numeric_limits<double>::epsilon() * resabs, err);
  p.splittable = (p.b - p.a) > 64.0 * std::numeric_limits<double>::epsilon() *
                                   std::max({1.0, std::abs(p.a), std::abs(p.b)});
}

}  // namespace

const OptionSpecs<AdaptiveQuadratureOptions>& AdaptiveQuadratureOptions::specs() {
  using A = AdaptiveQuadratureOptions;
  static const OptionSpecs<A> specs({
      option("relative_tolerance", &A::relative_tolerance,
             "target on the summed error estimate relative to the Frobenius norm of the integral")
          .range(Range::open(0, 1)),
      option("absolute_tolerance", &A::absolute_tolerance,
             "absolute floor on the summed error estimate (Frobenius norm), for integrals that "
             "may vanish")
          .range(Range::at_least(0).finite()),
      option("max_evaluations", &A::max_evaluations, "largest number of integrand evaluations")
          .range(Range::at_least(detail::kNodes))
          .because("one Gauss-Kronrod rule"),
      option("initial_intervals", &A::initial_intervals, "initial equal subintervals")
          .range(Range::at_least(1)),
  });
  return specs;
}

void AdaptiveQuadratureOptions::validate() const {
  specs().validate(*this, "AdaptiveQuadratureOptions");
}

AdaptiveQuadratureOptions band_quadrature_defaults() {
  AdaptiveQuadratureOptions q;
  q.max_evaluations = 20000;
  return q;
}

const OptionSpecs<AdaptiveQuadratureOptions>& band_quadrature_specs() {
  const auto& core = AdaptiveQuadratureOptions::specs();
  static const OptionSpecs<AdaptiveQuadratureOptions> specs({
      core.at("relative_tolerance")
          .renamed("band_quadrature_tolerance",
                   "relative tolerance of the adaptive quadrature of the band integrals L_B = ∫ "
                   "(iωE - A)^-1 B dω and L_C"),
      core.at("max_evaluations")
          .renamed("band_quadrature_budget",
                   "at most this many quadrature nodes (one factorisation each) for L_B, L_C"),
  });
  return specs;
}

MatrixQuadrature integrate_adaptive(const MatrixIntegrand& f, double a, double b,
                                    const AdaptiveQuadratureOptions& options) {
  options.validate();
  if (!(std::isfinite(a) && std::isfinite(b) && a < b)) {
    throw ConfigError("integrate_adaptive: the interval [" + detail::number_text(a) + ", " +
                      detail::number_text(b) + "] must be finite with a < b");
  }
  MatrixQuadrature result;
  Index rows = -1, cols = -1;
  auto evaluate = [&](std::vector<MatrixPiece>& batch) {
    std::vector<double> x(batch.size() * kNodes);
    for (std::size_t i = 0; i < batch.size(); ++i)
      detail::nodes_of(batch[i].a, batch[i].b, &x[i * kNodes]);
    const std::vector<Matrix> values = f(x);
    if (values.size() != x.size()) {
      throw InputError(
          fmt::format("integrate_adaptive: the integrand returned {} values for {} points",
                      values.size(), x.size()));
    }
    for (std::size_t i = 0; i < values.size(); ++i) {
      if (rows < 0) {
        rows = values[i].rows();
        cols = values[i].cols();
      }
      if (values[i].rows() != rows || values[i].cols() != cols) {
        throw InputError(fmt::format(
            "integrate_adaptive: the integrand is {} x {} at x = {} but {} x {} elsewhere",
            values[i].rows(), values[i].cols(), detail::number_text(x[i]), rows, cols));
      }
      if (!values[i].allFinite()) {
        throw InputError("integrate_adaptive: the integrand is not finite at x = " +
                         detail::number_text(x[i]));
      }
    }
    for (std::size_t i = 0; i < batch.size(); ++i) matrix_rule(batch[i], &values[i * kNodes]);
    result.evaluations += static_cast<Index>(x.size());
  };

  std::vector<MatrixPiece> pieces;
  for (Index i = 0; i < options.initial_intervals; ++i) {
    const double t0 = static_cast<double>(i) / static_cast<double>(options.initial_intervals);
    const double t1 = static_cast<double>(i + 1) / static_cast<double>(options.initial_intervals);
    pieces.push_back(MatrixPiece{a + (b - a) * t0,
                                 i + 1 == options.initial_intervals ? b : a + (b - a) * t1,
                                 {},
                                 0.0,
                                 true});
  }
  // The first round may not fit the budget: then one rule over the whole interval.
  if (options.initial_intervals * kNodes > options.max_evaluations)
    pieces = {MatrixPiece{a, b, {}, 0.0, true}};
  evaluate(pieces);

  while (true) {
    Matrix integral = Matrix::Zero(rows, cols);
    double error = 0.0;
    for (const MatrixPiece& p : pieces) {
      integral += p.kronrod;
      error += p.error;
    }
    result.integral = std::move(integral);
    result.error_estimate = error;
    const detail::Round round = detail::adaptive_round(
        pieces, error, result.integral.norm(), options.relative_tolerance,
        options.absolute_tolerance, options.max_evaluations - result.evaluations, evaluate);
    result.converged = round == detail::Round::Converged;
    if (round != detail::Round::Refined) break;
  }
  result.intervals = static_cast<Index>(pieces.size());
  std::sort(pieces.begin(), pieces.end(),
            [](const MatrixPiece& x, const MatrixPiece& y) { return x.a < y.a; });
  for (const MatrixPiece& piece : pieces) {
    double x[kNodes];
    detail::nodes_of(piece.a, piece.b, x);
    const double h = 0.5 * (piece.b - piece.a);
    result.nodes.push_back(x[0]);
    result.weights.push_back(h * detail::kWgk[7]);
    for (int j = 0; j < 7; ++j) {
      result.nodes.push_back(x[1 + 2 * j]);
      result.weights.push_back(h * detail::kWgk[j]);
      result.nodes.push_back(x[2 + 2 * j]);
      result.weights.push_back(h * detail::kWgk[j]);
    }
  }
  return result;
}

BandResolventIntegrals band_resolvent_integrals(FirstOrderView& view, const Band& band,
                                                const AdaptiveQuadratureOptions& options) {
  band.validate();
  const double w1 = kTwoPi * band.f_min_hz, w2 = kTwoPi * band.f_max_hz;
  const bool logarithmic = band.f_max_hz / band.f_min_hz > 4.0;
  const Index m = view.inputs(), p = view.outputs(), n = view.state_size();
  const ComplexMatrix eye_m = ComplexMatrix::Identity(m, m), eye_p = ComplexMatrix::Identity(p, p);
  const Matrix output = view.output_matrix();
  std::map<double, ComplexMatrix> response;  // G(i omega) at every node evaluated, by t
  // 2 Re[(i w E - A)^-1 B, (i w E - A)^-T C'] dw/dt at each node: the mirror image -B contributes
  // the complex conjugate of the same value (real matrices).
  const MatrixIntegrand integrand = [&](const std::vector<double>& t) {
    std::vector<Matrix> out(t.size());
    std::vector<ComplexMatrix> g(t.size());
    // Nodes in parallel, as frequency_response does (factorisations are independent).
    detail::parallel_for(
        static_cast<Index>(t.size()), view.solver().concurrent() ? 0 : 1, [&](Index k) {
          const double w = logarithmic ? std::exp(t[k]) : t[k];
          const double jacobian = logarithmic ? w : 1.0;
          const Complex s(0.0, w);
          std::shared_ptr<const Factorization> factor;
          try {
            factor = view.solver().factorize(s);
          } catch (const NumericalError& e) {
            throw NumericalError(fmt::format(
                "band_resolvent_integrals: factorisation at {} Hz failed (a pole on the imaginary "
                "axis inside the band?): {}",
                detail::number_text(w / kTwoPi), e.what()));
          }
          Matrix value(n, m + p);
          const ComplexMatrix x = view.right(*factor, s, eye_m);
          g[k] = output * x;
          value.leftCols(m) = (2.0 * jacobian) * x.real();
          value.rightCols(p) = (2.0 * jacobian) * view.left(*factor, s, eye_p).real();
          out[k] = std::move(value);
        });
    for (std::size_t k = 0; k < t.size(); ++k) response[t[k]] = std::move(g[k]);
    return out;
  };
  BandResolventIntegrals result;
  result.variable = logarithmic ? "log(omega)" : "omega";
  result.quadrature = logarithmic
                          ? integrate_adaptive(integrand, std::log(w1), std::log(w2), options)
                          : integrate_adaptive(integrand, w1, w2, options);
  result.input = result.quadrature.integral.leftCols(m);
  result.output = result.quadrature.integral.rightCols(p);
  const auto& q = result.quadrature;
  for (std::size_t k = 0; k < q.nodes.size(); ++k) {
    const double w = logarithmic ? std::exp(q.nodes[k]) : q.nodes[k];
    result.omega.push_back(w);
    result.weights.push_back(q.weights[k] * (logarithmic ? w : 1.0) / kPi);
    result.response.push_back(response.at(q.nodes[k]));
  }
  return result;
}

double band_h2_squared_error(const BandResolventIntegrals& integrals, const ReducedModel* reduced) {
  std::optional<ReducedResponse> gr;
  if (reduced != nullptr) gr.emplace(*reduced);
  double sum = 0.0;
  for (std::size_t k = 0; k < integrals.omega.size(); ++k) {
    const ComplexMatrix& g = integrals.response[k];
    sum += integrals.weights[k] *
           (gr ? (g - (*gr)(Complex(0.0, integrals.omega[k]))).squaredNorm() : g.squaredNorm());
  }
  return sum;
}

Complex band_pole_integral(Complex s, const Band& band) {
  band.validate();
  if (!(s.real() > 0.0)) {
    throw InputError("band_pole_integral: the point " + detail::number_text(s.real()) +
                     (s.imag() < 0 ? "" : "+") + detail::number_text(s.imag()) +
                     "i must have a positive real part");
  }
  const double w1 = kTwoPi * band.f_min_hz, w2 = kTwoPi * band.f_max_hz;
  return 2.0 * (std::atan(Complex(w2) / s) - std::atan(Complex(w1) / s));
}

}  // namespace ecmor
