// time_domain.cpp: fixed-step simulation of full and reduced models and the output error (Eq. 11).
//
// Why it looks like this:
//  * One integrator body per model kind, templated on the matrix type, serves the sparse full
//    model and the dense reduced model. A full-order "reduction" (V = W = I) then runs the same
//    floating-point operations in the same order up to the factorisation backend, which is what
//    lets the tests demand round-off agreement.
//  * The schemes are written in acceleration (rate) form: the unknown of each step is a_{n+1}
//    (x'_{n+1}), and the effective matrix multiplies it. That form needs the consistent initial
//    rate, hence one factorisation of M (E) besides the effective matrix. The alternative, starting
//    with a = 0 although u(0+) != 0 (a step), costs an O(h) error in the first step that stays in
//    the solution: the method would be first order for steps and impulses.
//  * The force enters the generalised-alpha balance interpolated, (1 - alpha_f) f_{n+1} +
//    alpha_f f_n (second order) / (1 - alpha_f) f_n + alpha_f f_{n+1} (first order, JWH
//    convention), not evaluated at the intermediate time: both are second order, the interpolated
//    form keeps Newmark / trapezoidal as the special case alpha_m = alpha_f = 0 (second order),
//    alpha_m = alpha_f = 1 (first order) exactly.
#include "ecmor/response/time_domain.hpp"

#include <fmt/core.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <type_traits>
#include <variant>

#include "ecmor/base/error.hpp"
#include "model/first_order_realisation.hpp"

namespace ecmor {

namespace {

using Clock = std::chrono::steady_clock;

// Below this reciprocal condition estimate a dense M, E or effective matrix counts as singular
// (the sparse backend's default SolverOptions::singular_rcond).
constexpr double kSingularRcond = 1e-14;

[[noreturn]] void fail_config(const std::string& field, const std::string& value,
                              const std::string& rule) {
  throw ConfigError(fmt::format("{} = {}: {}", field, value, rule));
}

std::string num(double x) { return fmt::format("{:g}", x); }

// Newmark / generalised-alpha parameters of the second-order scheme (Chung-Hulbert convention:
// the balance holds at x_{n+1-alpha} = (1 - alpha) x_{n+1} + alpha x_n).
struct SecondOrderParameters {
  double alpha_m = 0.0, alpha_f = 0.0, beta = 0.25, gamma = 0.5;
  std::string text;
};

SecondOrderParameters second_order_parameters(const TimeIntegrationOptions& o) {
  SecondOrderParameters p;
  if (o.scheme == TimeIntegrationOptions::Scheme::Newmark) {
    p.text = "Newmark average acceleration (beta = 1/4, gamma = 1/2)";
    return p;
  }
  const double rho = o.rho_inf;
  p.alpha_m = (2.0 * rho - 1.0) / (rho + 1.0);
  p.alpha_f = rho / (rho + 1.0);
  p.gamma = 0.5 - p.alpha_m + p.alpha_f;
  p.beta = 0.25 * (1.0 - p.alpha_m + p.alpha_f) * (1.0 - p.alpha_m + p.alpha_f);
  p.text = fmt::format(
      "generalized-alpha, Chung-Hulbert (rho_inf = {:g}: alpha_m = {:g}, alpha_f = {:g}, "
      "beta = {:g}, gamma = {:g})",
      rho, p.alpha_m, p.alpha_f, p.beta, p.gamma);
  return p;
}

// First-order parameters (Jansen-Whiting-Hulbert convention: the balance holds at
// x_{n+alpha} = x_n + alpha (x_{n+1} - x_n)). alpha_m = alpha_f = 1, gamma = 1/2 is the
// trapezoidal rule.
struct FirstOrderParameters {
  double alpha_m = 1.0, alpha_f = 1.0, gamma = 0.5;
  std::string text;
};

FirstOrderParameters first_order_parameters(const TimeIntegrationOptions& o) {
  FirstOrderParameters p;
  if (o.scheme == TimeIntegrationOptions::Scheme::Newmark) {
    p.text = "trapezoidal rule (Newmark average acceleration in first-order form)";
    return p;
  }
  const double rho = o.rho_inf;
  p.alpha_m = 0.5 * (3.0 - rho) / (1.0 + rho);
  p.alpha_f = 1.0 / (1.0 + rho);
  p.gamma = 0.5 + p.alpha_m - p.alpha_f;
  p.text = fmt::format(
      "generalized-alpha, first order, Jansen-Whiting-Hulbert (rho_inf = {:g}: alpha_m = {:g}, "
      "alpha_f = {:g}, gamma = {:g})",
      rho, p.alpha_m, p.alpha_f, p.gamma);
  return p;
}

// The input direction b = B w (w = e_input or ones(m)) after checking the index.
Vector input_direction(const Matrix& B, const InputSignal& input) {
  const Index m = B.cols();
  if (input.input < -1 || input.input >= m) {
    fail_config("InputSignal::input", std::to_string(input.input),
                fmt::format("must be -1 (all inputs) or a 0-based input index in [0, {}]", m - 1));
  }
  if (input.input == -1) return B.rowwise().sum();
  return B.col(input.input);
}

// A solve with a factorised matrix: x = S^-1 r.
using SolveFn = std::function<Vector(const Vector&)>;

struct Solvers {
  SolveFn effective;  // the effective matrix of the scheme
  SolveFn rate;       // M (second order) or E (descriptor)
};

template <class Mat>
void run(const SecondOrderSystem<Mat>& s, const Vector& b, const InputSignal& input,
         const TimeIntegrationOptions& o, const SecondOrderParameters& p, const Solvers& solve,
         TimeResponse& r) {
  const double h = o.step();
  const Index N = s.size();
  const bool vout = s.has_velocity_output();
  const double am = p.alpha_m, af = p.alpha_f, beta = p.beta, gamma = p.gamma;
  Vector q = Vector::Zero(N), v = Vector::Zero(N);
  if (input.kind == InputSignal::Kind::Impulse) v = solve.rate(b * input.amplitude);
  auto g = [&](double t) { return input.value(t, o.t_end); };
  // Consistent initial acceleration M a0 = b g(0+) - D v(0+) - K q(0+) (q(0+) = 0).
  Vector a = solve.rate(b * g(0.0) - s.D * v);
  auto output = [&](Index k) {
    r.y.col(k) = s.C * q;
    if (vout) r.y.col(k) += s.Cv * v;
  };
  output(0);
  Vector qs(N), vs(N), rhs(N);
  for (Index n = 0; n < o.steps; ++n) {
    const double gf = (1.0 - af) * g(r.t[n + 1]) + af * g(r.t[n]);
    qs = q + h * v + (h * h * (0.5 - beta)) * a;  // predictors
    vs = v + (h * (1.0 - gamma)) * a;
    rhs = gf * b - s.D * ((1.0 - af) * vs + af * v) - s.K * ((1.0 - af) * qs + af * q);
    if (am != 0.0) rhs -= am * (s.M * a);
    a = solve.effective(rhs);
    q = qs + (beta * h * h) * a;
    v = vs + (gamma * h) * a;
    output(n + 1);
  }
}

template <class Mat>
void run(const DescriptorSystem<Mat>& s, const Vector& b, const InputSignal& input,
         const TimeIntegrationOptions& o, const FirstOrderParameters& p, const Solvers& solve,
         TimeResponse& r) {
  const double h = o.step();
  const Index N = s.size();
  const double am = p.alpha_m, af = p.alpha_f, gamma = p.gamma;
  Vector x = Vector::Zero(N);
  if (input.kind == InputSignal::Kind::Impulse) x = solve.rate(b * input.amplitude);
  auto g = [&](double t) { return input.value(t, o.t_end); };
  // Consistent initial rate E x'(0) = A x(0+) + b g(0+).
  Vector xd = solve.rate(s.A * x + g(0.0) * b);
  r.y.col(0) = s.C * x;
  Vector rhs(N);
  for (Index n = 0; n < o.steps; ++n) {
    const double gf = (1.0 - af) * g(r.t[n]) + af * g(r.t[n + 1]);
    // (am E - af gamma h A) x'_{n+1} = A (x_n + af h (1 - gamma) x'_n) - (1 - am) E x'_n + b g_f
    rhs = s.A * (x + (af * h * (1.0 - gamma)) * xd) + gf * b;
    if (am != 1.0) rhs -= (1.0 - am) * (s.E * xd);
    const Vector xd_new = solve.effective(rhs);
    x += h * ((1.0 - gamma) * xd + gamma * xd_new);
    xd = xd_new;
    r.y.col(n + 1) = s.C * x;
  }
}

TimeResponse prepare(Index outputs, const TimeIntegrationOptions& o) {
  TimeResponse r;
  r.dt = o.step();
  r.t.resize(static_cast<std::size_t>(o.steps) + 1);
  // t_k = k h exactly as the sparse and the dense run both see it; the last point is t_end.
  for (Index k = 0; k <= o.steps; ++k) r.t[static_cast<std::size_t>(k)] = k * r.dt;
  r.t.back() = o.t_end;
  r.y.resize(outputs, o.steps + 1);
  return r;
}

void finish(TimeResponse& r, Clock::time_point t0, const char* what) {
  r.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  if (!r.y.allFinite()) {
    throw NumericalError(fmt::format("simulate ({}): the output became non-finite ({}, h = {:g} s)",
                                     what, r.scheme, r.dt));
  }
}

// Sparse: factorise a combination; a singular M / E is an input error, named.
std::shared_ptr<const Factorization> factorize_rate(ShiftedSolver& solver,
                                                    std::vector<Complex> weights,
                                                    const char* name) {
  try {
    return solver.factorize_combination(weights);
  } catch (const NumericalError& e) {
    throw InputError(fmt::format(
        "simulate: {0} is singular ({1}): refused, since the consistent initial rate and the "
        "impulse's initial state need {0}^-1 (DAEs with singular {0} are not supported)",
        name, e.what()));
  }
}

SolveFn sparse_solve(std::shared_ptr<const Factorization> f, Index& solves) {
  return [f = std::move(f), &solves](const Vector& rhs) -> Vector {
    ++solves;
    const Matrix x = f->solve(Matrix(rhs));
    return x.col(0);
  };
}

SolveFn dense_solve(const Matrix& S, const std::string& name, Index& factorizations,
                    Index& solves) {
  auto lu = std::make_shared<Eigen::PartialPivLU<Matrix>>(S);
  ++factorizations;
  // Eigen's rcond estimate stays finite for an exactly zero pivot; the pivot ratio catches that.
  const Vector pivots = lu->matrixLU().diagonal().cwiseAbs();
  const double pivot_ratio = pivots.maxCoeff() > 0.0 ? pivots.minCoeff() / pivots.maxCoeff() : 0.0;
  const double rc = std::min(lu->rcond(), pivot_ratio);
  if (!(rc >= kSingularRcond)) {
    if (name == "Mr" || name == "Er") {
      throw InputError(fmt::format(
          "simulate: {0} is singular (reciprocal condition {1:.3g} < {2:g}): refused, since the "
          "consistent initial rate and the impulse's initial state need {0}^-1",
          name, rc, kSingularRcond));
    }
    throw NumericalError(fmt::format(
        "simulate: the effective matrix {} is singular (reciprocal condition {:.3g})", name, rc));
  }
  return [lu, &solves](const Vector& rhs) -> Vector {
    ++solves;
    return lu->solve(rhs);
  };
}

}  // namespace

double InputSignal::value(double t, double t_end) const {
  switch (kind) {
    case Kind::Step:
      return amplitude;
    case Kind::Impulse:
      return 0.0;
    case Kind::Chirp:
      return amplitude * std::sin(kTwoPi * (f0_hz * t + (f1_hz - f0_hz) * t * t / (2.0 * t_end)));
  }
  return 0.0;
}

void InputSignal::validate() const {
  if (!std::isfinite(amplitude) || amplitude == 0.0)
    fail_config("InputSignal::amplitude", num(amplitude), "must be finite and non-zero");
  if (input < -1)
    fail_config("InputSignal::input", std::to_string(input),
                "must be -1 (all inputs) or a 0-based input index >= 0");
  if (kind == Kind::Chirp) {
    if (!std::isfinite(f0_hz) || f0_hz <= 0.0)
      fail_config("InputSignal::f0_hz", num(f0_hz), "must be finite and > 0 (chirp)");
    if (!std::isfinite(f1_hz) || f1_hz <= 0.0)
      fail_config("InputSignal::f1_hz", num(f1_hz), "must be finite and > 0 (chirp)");
  }
}

std::string to_string(InputSignal::Kind kind) {
  switch (kind) {
    case InputSignal::Kind::Step:
      return "step";
    case InputSignal::Kind::Impulse:
      return "impulse";
    case InputSignal::Kind::Chirp:
      return "chirp";
  }
  return "?";
}

InputSignal::Kind parse_input_kind(const std::string& name) {
  if (name == "step") return InputSignal::Kind::Step;
  if (name == "impulse") return InputSignal::Kind::Impulse;
  if (name == "chirp") return InputSignal::Kind::Chirp;
  fail_config("input", "'" + name + "'", "must be one of step, impulse, chirp");
}

void TimeIntegrationOptions::validate() const {
  if (!std::isfinite(t_end) || t_end <= 0.0)
    fail_config("TimeIntegrationOptions::t_end", num(t_end), "must be finite and > 0");
  if (steps < 1 || steps > 1000000000)
    fail_config("TimeIntegrationOptions::steps", std::to_string(steps), "must be in [1, 1e9]");
  if (!(rho_inf >= 0.0 && rho_inf <= 1.0))
    fail_config("TimeIntegrationOptions::rho_inf", num(rho_inf), "must be in [0, 1]");
}

std::string to_string(TimeIntegrationOptions::Scheme scheme) {
  return scheme == TimeIntegrationOptions::Scheme::Newmark ? "newmark" : "generalized-alpha";
}

TimeIntegrationOptions::Scheme parse_scheme(const std::string& name) {
  if (name == "newmark" || name == "trapezoidal") return TimeIntegrationOptions::Scheme::Newmark;
  if (name == "generalized-alpha") return TimeIntegrationOptions::Scheme::GeneralizedAlpha;
  fail_config("scheme", "'" + name + "'",
              "must be one of newmark (alias trapezoidal), generalized-alpha");
}

TimeResponse simulate(const Model& model, ShiftedSolver& solver, const InputSignal& input,
                      const TimeIntegrationOptions& options) {
  input.validate();
  options.validate();
  const auto t0 = Clock::now();
  const Index N = size_of(model);
  const Index terms = kind_of(model) == ModelKind::SecondOrder ? 3 : 2;
  if (solver.size() != N || solver.terms() != terms) {
    throw InputError(fmt::format(
        "simulate: the solver (N = {}, {} terms) is not bound to this model (N = {}, {} terms)",
        solver.size(), solver.terms(), N, terms));
  }
  const double h = options.step();
  TimeResponse r = prepare(outputs_of(model), options);
  Index solves = 0;
  std::visit(
      [&](const auto& s) {
        const Vector b = input_direction(s.B, input);
        Solvers solve;
        if constexpr (std::is_same_v<std::decay_t<decltype(s)>, SecondOrderModel>) {
          const SecondOrderParameters p = second_order_parameters(options);
          r.scheme = p.text;
          // Weights of (K, D, M).
          const std::vector<Complex> w = {(1.0 - p.alpha_f) * p.beta * h * h,
                                          (1.0 - p.alpha_f) * p.gamma * h, 1.0 - p.alpha_m};
          solve.rate = sparse_solve(factorize_rate(solver, {0.0, 0.0, 1.0}, "M"), solves);
          solve.effective = sparse_solve(solver.factorize_combination(w), solves);
          run(s, b, input, options, p, solve, r);
        } else {
          const FirstOrderParameters p = first_order_parameters(options);
          r.scheme = p.text;
          // Weights of (-A, E).
          const std::vector<Complex> w = {p.alpha_f * p.gamma * h, p.alpha_m};
          solve.rate = sparse_solve(factorize_rate(solver, {0.0, 1.0}, "E"), solves);
          solve.effective = sparse_solve(solver.factorize_combination(w), solves);
          run(s, b, input, options, p, solve, r);
        }
      },
      model);
  r.factorizations = 2;
  r.solves = solves;
  finish(r, t0, "full model");
  return r;
}

TimeResponse simulate(const ReducedModel& model, const InputSignal& input,
                      const TimeIntegrationOptions& options) {
  input.validate();
  options.validate();
  const auto t0 = Clock::now();
  const double h = options.step();
  TimeResponse r = prepare(outputs_of(model), options);
  Index solves = 0, factorizations = 0;
  std::visit(
      [&](const auto& s) {
        const Vector b = input_direction(s.B, input);
        Solvers solve;
        if constexpr (std::is_same_v<std::decay_t<decltype(s)>, ReducedSecondOrderModel>) {
          const SecondOrderParameters p = second_order_parameters(options);
          r.scheme = p.text;
          solve.rate = dense_solve(s.M, "Mr", factorizations, solves);
          const Matrix S = (1.0 - p.alpha_m) * s.M + ((1.0 - p.alpha_f) * p.gamma * h) * s.D +
                           ((1.0 - p.alpha_f) * p.beta * h * h) * s.K;
          solve.effective = dense_solve(S, "(1 - alpha_m) Mr + ... Kr", factorizations, solves);
          run(s, b, input, options, p, solve, r);
        } else {
          const FirstOrderParameters p = first_order_parameters(options);
          r.scheme = p.text;
          solve.rate = dense_solve(s.E, "Er", factorizations, solves);
          const Matrix S = p.alpha_m * s.E - (p.alpha_f * p.gamma * h) * s.A;
          solve.effective =
              dense_solve(S, "alpha_m Er - alpha_f gamma h Ar", factorizations, solves);
          run(s, b, input, options, p, solve, r);
        }
      },
      model);
  r.factorizations = factorizations;
  r.solves = solves;
  finish(r, t0, "reduced model");
  return r;
}

OutputError output_error(const TimeResponse& full, const TimeResponse& reduced) {
  if (full.t.size() != reduced.t.size() || full.t.empty()) {
    throw InputError(fmt::format(
        "output_error: the time grids differ: {} samples (full) and {} (reduced): must be equal "
        "and non-empty",
        full.t.size(), reduced.t.size()));
  }
  const double t_end = full.t.back();
  for (std::size_t k = 0; k < full.t.size(); ++k) {
    if (std::abs(full.t[k] - reduced.t[k]) > 1e-12 * std::abs(t_end)) {
      throw InputError(fmt::format(
          "output_error: the time grids differ at sample {}: t = {:g} (full) and {:g} (reduced)", k,
          full.t[k], reduced.t[k]));
    }
  }
  const auto samples = static_cast<Index>(full.t.size());
  if (full.y.rows() != reduced.y.rows() || full.y.cols() != samples ||
      reduced.y.cols() != samples) {
    throw InputError(fmt::format(
        "output_error: the outputs differ: y is {} x {} (full), yr is {} x {} (reduced): must "
        "both be p x {}",
        full.y.rows(), full.y.cols(), reduced.y.rows(), reduced.y.cols(), samples));
  }
  OutputError out;
  out.e = full.y - reduced.y;
  // L2 in time by the trapezoidal rule on the (possibly non-uniform) grid.
  auto l2 = [&](const Matrix& z) {
    double sum = 0.0;
    for (Index k = 0; k + 1 < samples; ++k) {
      const double dt = full.t[k + 1] - full.t[k];
      sum += 0.5 * dt * (z.col(k).squaredNorm() + z.col(k + 1).squaredNorm());
    }
    return std::sqrt(sum);
  };
  out.l2 = l2(out.e);
  out.y_l2 = l2(full.y);
  out.y_max = full.y.size() > 0 ? full.y.cwiseAbs().maxCoeff() : 0.0;
  Index row = 0, col = 0;
  out.max = out.e.size() > 0 ? out.e.cwiseAbs().maxCoeff(&row, &col) : 0.0;
  out.t_max = full.t[static_cast<std::size_t>(col)];
  out.relative_defined = out.y_l2 > 0.0 && out.y_max > 0.0;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  out.relative_l2 = out.relative_defined ? out.l2 / out.y_l2 : nan;
  out.relative_max = out.relative_defined ? out.max / out.y_max : nan;
  return out;
}

TimeSpan suggest_time_span(const ReducedModel& model, InputSignal::Kind input, double f_min_hz,
                           double f_max_hz) {
  if (!(f_min_hz > 0.0 && f_max_hz > f_min_hz && std::isfinite(f_max_hz)))
    throw ConfigError(
        fmt::format("suggest_time_span: band [{:g}, {:g}] Hz: must satisfy 0 < "
                    "f_min_hz < f_max_hz",
                    f_min_hz, f_max_hz));
  TimeSpan band;
  band.t_end = 5.0 / f_min_hz;
  band.f_fast_hz = f_max_hz;
  band.steps = static_cast<Index>(std::min(1e12, std::ceil(20.0 * f_max_hz * band.t_end)));
  band.reason = "5 periods of the band's lowest frequency, 20 steps per period of its highest";
  if (input == InputSignal::Kind::Chirp) return band;
  // A reciprocal condition of M_r (E_r) down to 1e-12: the poles and residues only choose a span.
  const std::optional<detail::FirstOrderRealisation> sys =
      detail::first_order_realisation(model, 1e-12);
  if (!sys || sys->F.rows() == 0) {
    band.reason += " (the reduced mass or descriptor matrix is singular: no modal terms)";
    return band;
  }
  Eigen::EigenSolver<Matrix> eig(sys->F, true);
  if (eig.info() != Eigen::Success) {
    band.reason += " (the reduced model's eigenvalues did not converge)";
    return band;
  }
  const ComplexVector p = eig.eigenvalues();
  const ComplexMatrix V = eig.eigenvectors();
  Eigen::PartialPivLU<ComplexMatrix> vlu(V);
  if (!(vlu.rcond() > 1e-12)) {
    band.reason +=
        " (a repeated pole without independent modes, such as the double pole at 0 of a "
        "rigid-body mode: the response need not settle)";
    return band;
  }
  const ComplexMatrix Y = vlu.solve(sys->G.cast<Complex>());  // rows: w_i^T G
  const ComplexMatrix LV = sys->L.cast<Complex>() * V;        // columns: L v_i
  const Index n = p.size();
  // Amplitude of each modal term of the response: ||L v_i|| ||w_i^T G|| (impulse), over |p_i|
  // for a step (the term (R_i / p_i) e^(p_i t)); a pole at 0 gives an infinite amplitude.
  std::vector<double> amplitude(static_cast<std::size_t>(n));
  double largest = 0.0;
  for (Index i = 0; i < n; ++i) {
    double a = LV.col(i).norm() * Y.row(i).norm();
    if (input == InputSignal::Kind::Step) a /= std::abs(p(i));
    amplitude[static_cast<std::size_t>(i)] = std::isnan(a) ? 0.0 : a;
    largest = std::max(largest, amplitude[static_cast<std::size_t>(i)]);
  }
  if (!(largest > 0.0)) {
    band.reason += " (no pole of the reduced model is seen at its outputs)";
    return band;
  }
  double slowest_rate = std::numeric_limits<double>::infinity();
  double fastest_hz = 0.0;
  for (Index i = 0; i < n; ++i) {
    if (!(amplitude[static_cast<std::size_t>(i)] >= 1e-3 * largest)) continue;
    const double rate = -p(i).real();
    if (!(rate > 1e-12 * std::abs(p(i))) ||
        !std::isfinite(amplitude[static_cast<std::size_t>(i)])) {
      band.reason += fmt::format(
          " (a term that matters does not decay: pole {:.3g}{:+.3g}i, a "
          "rigid-body, undamped or unstable mode)",
          p(i).real(), p(i).imag());
      return band;
    }
    slowest_rate = std::min(slowest_rate, rate);
    fastest_hz = std::max(fastest_hz, std::abs(p(i)) / kTwoPi);
  }
  TimeSpan out;
  out.from_poles = true;
  out.tau_slow = 1.0 / slowest_rate;
  out.t_end = std::min(band.t_end, 5.0 * out.tau_slow);
  out.f_fast_hz = std::min(f_max_hz, fastest_hz);
  out.steps = std::max<Index>(
      200, static_cast<Index>(std::min(1e12, std::ceil(20.0 * out.f_fast_hz * out.t_end))));
  out.reason = fmt::format(
      "5 time constants of the slowest decaying term of the response that matters (tau = {:.3g} "
      "s{}), 20 steps per period of its fastest ({:.3g} Hz)",
      out.tau_slow, out.t_end < 5.0 * out.tau_slow ? ", capped at 5 / f_min" : "", out.f_fast_hz);
  return out;
}

}  // namespace ecmor
