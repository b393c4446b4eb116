// hinf_norm.cpp: H-infinity norms of dense models by the level-set (Hamiltonian) method of
// Boyd-Balakrishnan / Bruinsma-Steinbuch.
#include "ecmor/hinf_norm.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "ecmor/error.hpp"
#include "ecmor/frequency_response.hpp"
#include "ecmor/lyapunov.hpp"
#include "ecmor/reduced_response.hpp"
#include "number_text.hpp"

namespace ecmor {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();
const char* const kMethod = "level set (Bruinsma-Steinbuch)";

/// x' = F x + G u, y = L x.
struct StateSpace {
  Matrix F, G, L;
};

/// Refuses a model with a pole of real part >= 0 (or NaN), naming the worst one.
void require_stable(const ReducedModel& model, std::string_view origin) {
  const ComplexVector p = poles(model);
  Index count = 0;
  Complex worst(-std::numeric_limits<double>::infinity(), 0.0);
  for (const Complex& z : p) {
    if (z.real() < 0.0) continue;  // NaN fails this test too
    ++count;
    if (std::isnan(z.real()) || !(worst.real() >= z.real())) worst = z;
  }
  if (count > 0)
    throw InputError(std::string(origin) + ": the model has " + std::to_string(count) +
                     " pole(s) with Re >= 0 (e.g. " + detail::number_text(worst) +
                     "); the H-infinity norm needs an asymptotically stable model");
}

/// The standard state space of a dense model (E removed by LU; fine for the small dense models
/// this is meant for), after the stability check.
StateSpace state_space(const ReducedModel& model, std::string_view origin) {
  validate(model, origin);
  const ReducedDescriptorModel r = first_order_realization(model);
  const Eigen::PartialPivLU<Matrix> lu(r.E);
  // rcond of a singular matrix can come back NaN: the negated test refuses it too.
  // The pivots too: the rcond estimate of an exactly singular matrix can come back large.
  const Vector pivots = lu.matrixLU().diagonal().cwiseAbs();
  const double rcond = std::min(lu.rcond(), pivots.minCoeff() / pivots.maxCoeff());
  if (!(rcond > static_cast<double>(r.E.rows()) * kEps))
    throw InputError(
        std::string(origin) + ": " + (kind_of(model) == ModelKind::SecondOrder ? "M" : "E") +
        " is numerically singular (reciprocal condition " + detail::number_text(rcond) +
        "): descriptor models (DAEs) are not supported by the H-infinity norm");
  require_stable(model, origin);
  return StateSpace{lu.solve(r.A), lu.solve(r.B), r.C};
}

void require_same_io(const ReducedModel& a, const ReducedModel& b, std::string_view origin) {
  if (inputs_of(a) != inputs_of(b) || outputs_of(a) != outputs_of(b))
    throw InputError(std::string(origin) + ": the models have " + std::to_string(outputs_of(a)) +
                     " x " + std::to_string(inputs_of(a)) + " and " +
                     std::to_string(outputs_of(b)) + " x " + std::to_string(inputs_of(b)) +
                     " transfer matrices (outputs x inputs): they must be equal");
}

/// sigma_max of Ga(i w) (- Gb(i w)), both by Laub's Hessenberg method.
class Sigma {
 public:
  Sigma(const ReducedModel& a, const ReducedModel* b) : m_a(a) {
    if (b != nullptr) m_b.emplace(*b);
  }
  double operator()(double omega) {
    ++m_count;
    const Complex s(0.0, omega);
    ComplexMatrix h = m_a(s);
    if (m_b) h -= (*m_b)(s);
    if (h.size() == 1) return std::abs(h(0, 0));
    return Eigen::JacobiSVD<ComplexMatrix>(h).singularValues()(0);
  }
  Index count() const { return m_count; }

 private:
  ReducedResponse m_a;
  std::optional<ReducedResponse> m_b;
  Index m_count = 0;
};

/// The imaginary parts of the eigenvalues of H(gamma) that lie on the imaginary axis.
std::vector<double> imaginary_eigenvalues(const StateSpace& ss, double gamma) {
  const Index n = ss.F.rows();
  Matrix H(2 * n, 2 * n);
  H.topLeftCorner(n, n) = ss.F;
  H.topRightCorner(n, n) = ss.G * ss.G.transpose() / gamma;
  H.bottomLeftCorner(n, n) = -ss.L.transpose() * ss.L / gamma;
  H.bottomRightCorner(n, n) = -ss.F.transpose();
  const Eigen::EigenSolver<Matrix> es(H, false);
  if (es.info() != Eigen::Success)
    throw NumericalError("H-infinity norm: the eigenvalue iteration on the Hamiltonian of size " +
                         std::to_string(2 * n) + " at level " + detail::number_text(gamma) +
                         " did not converge");
  // The eigensolver does not preserve the Hamiltonian structure, so eigenvalues on the axis come
  // back with rounding-size real parts (measured: 4e-12 relative on cdplayer), larger where two
  // crossings nearly coincide (gamma just below a peak). A crossing missed here could end the
  // iteration early; an off-axis eigenvalue admitted wrongly only adds midpoints to evaluate,
  // which the midpoint test of level_set then discards. So the threshold is generous:
  // |Re| <= 1e-4 |lambda|, i.e. eigenvalues next to poles of damping ratio below ~1e-4 are tried
  // too. (Just above a sharp peak the off-axis quadruple sits at only ~sqrt(2 tol) zeta |lambda|,
  // 2e-7 relative on cdplayer: no threshold separates it from a crossing, the midpoint test does.)
  constexpr double tau = 1e-4;
  const double floor = 100.0 * kEps * H.lpNorm<1>();
  std::vector<double> omegas;
  for (const Complex& z : es.eigenvalues())
    if (std::abs(z.real()) <= tau * std::abs(z) + floor) omegas.push_back(z.imag());
  std::sort(omegas.begin(), omegas.end());
  return omegas;
}

HinfResult level_set(StateSpace ss, const ReducedModel& a, const ReducedModel* b,
                     const HinfOptions& options) {
  options.validate();
  HinfResult result;
  result.method = kMethod;
  Sigma sigma(a, b);
  // Test frequencies for the first lower bound (Bruinsma-Steinbuch take 0 and the least damped
  // pole's |lambda|): 0 and, for every pole, Im(lambda) and |lambda|. At O(n^2) per evaluation this
  // costs less than one Hamiltonian iteration and usually starts next to the global peak.
  const Eigen::EigenSolver<Matrix> es(ss.F, false);
  std::vector<double> tests{0.0};
  if (es.info() == Eigen::Success)
    for (const Complex& z : es.eigenvalues()) {
      if (z.imag() > 0.0) tests.push_back(z.imag());
      if (z.imag() >= 0.0) tests.push_back(std::abs(z));
    }
  double lower = 0.0, omega_lower = 0.0;
  for (double w : tests) {
    const double v = sigma(w);
    if (v > lower) {
      lower = v;
      omega_lower = w;
    }
  }
  const auto finish = [&](bool converged, std::string message) {
    result.value = lower;
    result.omega_peak_rad_s = omega_lower;
    result.f_peak_hz = omega_lower / kTwoPi;
    result.converged = converged;
    result.upper_bound = converged ? lower * (1.0 + 2.0 * options.relative_tolerance)
                                   : std::numeric_limits<double>::infinity();
    result.evaluations = sigma.count();
    result.message = std::move(message);
    return result;
  };
  if (lower == 0.0)
    // A nonzero transfer matrix of order n (numerators of degree < n) vanishes at fewer than n
    // frequencies; there are at least n + 1 test frequencies (distinct unless poles repeat).
    // Exactly zero everywhere happens for B = 0, C = 0 or a model against itself.
    return finish(true, "the transfer matrix is exactly zero at all " +
                            std::to_string(tests.size()) + " test frequencies");

  // Balancing G against L leaves the transfer matrix unchanged and keeps the two off-diagonal
  // blocks of the Hamiltonian of similar size (better conditioned eigenvalues).
  const double gn = ss.G.norm(), ln = ss.L.norm();
  if (gn > 0.0 && ln > 0.0) {
    const double alpha = std::sqrt(ln / gn);
    ss.G *= alpha;
    ss.L /= alpha;
  }

  const double tol = options.relative_tolerance;
  for (Index it = 0; it < options.max_iterations; ++it) {
    const double gamma = (1.0 + 2.0 * tol) * lower;
    const std::vector<double> omegas = imaginary_eigenvalues(ss, gamma);
    ++result.iterations;
    if (omegas.empty())
      return finish(true, "no imaginary-axis eigenvalue at level " + detail::number_text(gamma) +
                              " after " + std::to_string(result.iterations) + " iteration(s)");
    // sigma_max > gamma on some of the intervals between consecutive crossing frequencies
    // (conjugate symmetry: |omega| is evaluated). Their midpoints raise the lower bound.
    double best = 0.0, omega_best = 0.0;
    for (std::size_t i = 0; i + 1 < omegas.size(); ++i) {
      const double w = std::abs(0.5 * (omegas[i] + omegas[i + 1]));
      const double v = sigma(w);
      if (v > best) {
        best = v;
        omega_best = w;
      }
    }
    if (best > lower) {
      lower = best;
      omega_lower = omega_best;
    }
    // Between consecutive true crossings sigma_max - gamma keeps its sign, and it is positive
    // between some pair if sigma_max exceeds gamma anywhere (it tends to 0 at infinity). Spurious
    // candidates only split those intervals, whose midpoints still lie inside them. So if no
    // midpoint exceeds gamma, the norm is at most gamma: the Bruinsma-Steinbuch certificate, as
    // is an empty candidate list above.
    if (!(best > gamma))
      return finish(true, "no midpoint between the " + std::to_string(omegas.size()) +
                              " candidate crossings at level " + detail::number_text(gamma) +
                              " exceeds it, after " + std::to_string(result.iterations) +
                              " iteration(s)");
  }
  return finish(false, "not converged in " + std::to_string(options.max_iterations) +
                           " iterations: " + detail::number_text(lower) + " is a lower bound");
}

}  // namespace

void HinfOptions::validate() const {
  if (!(relative_tolerance >= 1e-14 && relative_tolerance <= 0.1))
    throw ConfigError("HinfOptions::relative_tolerance = " +
                      detail::number_text(relative_tolerance) + ": must be in [1e-14, 0.1]");
  if (max_iterations < 1)
    throw ConfigError("HinfOptions::max_iterations = " + std::to_string(max_iterations) +
                      ": must be >= 1");
}

HinfResult hinf_norm(const ReducedModel& model, const HinfOptions& options) {
  options.validate();
  return level_set(state_space(model, "hinf_norm"), model, nullptr, options);
}

HinfResult hinf_error_norm(const ReducedModel& a, const ReducedModel& b,
                           const HinfOptions& options) {
  options.validate();
  require_same_io(a, b, "hinf_error_norm");
  const StateSpace sa = state_space(a, "hinf_error_norm: first model");
  const StateSpace sb = state_space(b, "hinf_error_norm: second model");
  const Index na = sa.F.rows(), nb = sb.F.rows();
  StateSpace e{Matrix::Zero(na + nb, na + nb), Matrix(na + nb, sa.G.cols()),
               Matrix(sa.L.rows(), na + nb)};
  e.F.topLeftCorner(na, na) = sa.F;
  e.F.bottomRightCorner(nb, nb) = sb.F;
  e.G << sa.G, sb.G;
  e.L << sa.L, -sb.L;
  return level_set(std::move(e), a, &b, options);
}

}  // namespace ecmor
