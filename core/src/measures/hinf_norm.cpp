// hinf_norm.cpp: H-infinity norms of dense models by the level-set (Hamiltonian) method of
// Boyd-Balakrishnan / Bruinsma-Steinbuch.
#include "ecmor/measures/hinf_norm.hpp"

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
#include <variant>
#include <vector>

#include "base/number_text.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/gramians/lyapunov.hpp"
#include "ecmor/model/dense_model.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/response/reduced_response.hpp"
#include "linalg/dense_lapack.hpp"
#include "model/model_checks.hpp"

namespace ecmor {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();
const char* const kMethod = "level set (Bruinsma-Steinbuch)";

/// E x' = A x + B u, y = C x (E nonsingular). When E is diagonal, E^-1 A and E^-1 B are row
/// scalings, exact to rounding in every entry, and the realisation is kept in that form
/// (E = I, e_identity = true) for the cheaper standard eigensolver; otherwise E stays in the
/// pencil: E^-1 A formed by a solve loses accuracy with cond(E) (measured on lf10, cond(M) = 2e6:
/// the static gain through M^-1 K came out 1.8e-5 too large).
struct Pencil {
  Matrix E, A, B, C;
  bool e_identity = false;
};

bool is_diagonal(const Matrix& X) {
  for (Index j = 0; j < X.cols(); ++j)
    for (Index i = 0; i < X.rows(); ++i)
      if (i != j && X(i, j) != 0.0) return false;
  return true;
}

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

/// The first-order pencil of a dense model, after the checks (E nonsingular, stable).
Pencil pencil_of(const ReducedModel& model, std::string_view origin) {
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
  if (!is_diagonal(r.E)) return Pencil{r.E, r.A, r.B, r.C, false};
  const Vector inv = r.E.diagonal().cwiseInverse();
  const Index n = r.E.rows();
  return Pencil{Matrix::Identity(n, n), inv.asDiagonal() * r.A, inv.asDiagonal() * r.B, r.C, true};
}

/// G(s) of one model. Laub's Hessenberg method (ReducedResponse, O(n^2) per frequency) when it
/// forms E^-1 A (M^-1 K, M^-1 D) exactly, i.e. E (M) diagonal; otherwise a dense LU of
/// s^2 M + s D + K (second order) or s E - A per frequency, O(n^3) but without the inverse of a
/// possibly ill-conditioned E (M). For second-order models that is an n x n LU against the
/// Hamiltonian of size 4n per iteration, so it costs less than the level-set iterations.
class Response {
 public:
  explicit Response(const ReducedModel& model) : m_model(model) {
    if (const auto* s = std::get_if<ReducedSecondOrderModel>(&model))
      m_direct = !is_diagonal(s->M);
    else
      m_direct = !is_diagonal(std::get<ReducedDescriptorModel>(model).E);
    if (!m_direct) m_hessenberg.emplace(model);
  }
  ComplexMatrix operator()(Complex s) const {
    if (!m_direct) return (*m_hessenberg)(s);
    if (const auto* m = std::get_if<ReducedSecondOrderModel>(&m_model)) {
      const ComplexMatrix P =
          (s * s) * m->M.cast<Complex>() + s * m->D.cast<Complex>() + m->K.cast<Complex>();
      ComplexMatrix C = m->C.cast<Complex>();
      if (m->has_velocity_output()) C += s * m->Cv.cast<Complex>();
      return C * P.partialPivLu().solve(m->B.cast<Complex>());
    }
    const auto& d = std::get<ReducedDescriptorModel>(m_model);
    const ComplexMatrix P = s * d.E.cast<Complex>() - d.A.cast<Complex>();
    return d.C.cast<Complex>() * P.partialPivLu().solve(d.B.cast<Complex>());
  }

 private:
  ReducedModel m_model;
  bool m_direct = false;
  std::optional<ReducedResponse> m_hessenberg;
};

/// sigma_max of Ga(i w) (- Gb(i w)).
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
  Response m_a;
  std::optional<Response> m_b;
  Index m_count = 0;
};

/// The imaginary parts of the eigenvalues of the Hamiltonian pencil
///     s [[E, 0], [0, E']] - [[A, B B' / gamma], [-C' C / gamma, -A']]
/// that lie on the imaginary axis: [x; lambda] with (s E - A) x = B B' lambda / gamma and
/// (-s E' - A') lambda = C' C x / gamma gives gamma^2 u = G(-s)' G(s) u for u = B' lambda / gamma,
/// so i omega is an eigenvalue exactly when gamma is a singular value of G(i omega). With E = I
/// this is the Hamiltonian matrix of F = E^-1 A (standard eigensolver); otherwise real QZ on the
/// pencil, so that E is never inverted.
std::vector<double> imaginary_eigenvalues(const Pencil& ss, double gamma) {
  const Index n = ss.A.rows();
  Matrix H(2 * n, 2 * n);
  H.topLeftCorner(n, n) = ss.A;
  H.topRightCorner(n, n) = ss.B * ss.B.transpose() / gamma;
  H.bottomLeftCorner(n, n) = -ss.C.transpose() * ss.C / gamma;
  H.bottomRightCorner(n, n) = -ss.A.transpose();
  const auto failed = [&] {
    return NumericalError("H-infinity norm: the eigenvalue iteration on the Hamiltonian of size " +
                          std::to_string(2 * n) + " at level " + detail::number_text(gamma) +
                          " did not converge");
  };
  ComplexVector lambda;
  double scale = H.lpNorm<1>();
  if (ss.e_identity) {
    const Eigen::EigenSolver<Matrix> es(H, false);
    if (es.info() != Eigen::Success) throw failed();
    lambda = es.eigenvalues();
  } else {
    Matrix N = Matrix::Zero(2 * n, 2 * n);
    N.topLeftCorner(n, n) = ss.E;
    N.bottomRightCorner(n, n) = ss.E.transpose();
    ComplexVector alpha;
    Vector beta;
    if (!detail::generalized_eigenvalues(H, N, alpha, beta)) throw failed();
    // E is nonsingular (checked), so every beta is nonzero in exact arithmetic; a rounding-size
    // beta would stand for an eigenvalue beyond any frequency of interest. (dggev scales neither
    // side: the floor is relative to N's norm, as it was with Eigen's RealQZ.)
    const double beta_floor = 100.0 * kEps * N.lpNorm<1>();
    std::vector<Complex> finite;
    for (Index i = 0; i < beta.size(); ++i)
      if (std::abs(beta(i)) > beta_floor) finite.push_back(alpha(i) / beta(i));
    lambda = Eigen::Map<ComplexVector>(finite.data(), static_cast<Index>(finite.size()));
    scale /= N.lpNorm<1>();
  }
  // Neither eigensolver preserves the Hamiltonian structure, so eigenvalues on the axis come
  // back with rounding-size real parts (measured: 4e-12 relative on cdplayer), larger where two
  // crossings nearly coincide (gamma just below a peak). A crossing missed here could end the
  // iteration early; an off-axis eigenvalue admitted wrongly only adds midpoints to evaluate,
  // which the midpoint test of level_set then discards. So the threshold is generous:
  // |Re| <= 1e-4 |lambda|, i.e. eigenvalues next to poles of damping ratio below ~1e-4 are tried
  // too. (Just above a sharp peak the off-axis quadruple sits at only ~sqrt(2 tol) zeta |lambda|,
  // 2e-7 relative on cdplayer: no threshold separates it from a crossing, the midpoint test does.)
  constexpr double tau = 1e-4;
  const double floor = 100.0 * kEps * scale;
  std::vector<double> omegas;
  for (const Complex& z : lambda)
    if (std::abs(z.real()) <= tau * std::abs(z) + floor) omegas.push_back(z.imag());
  std::sort(omegas.begin(), omegas.end());
  return omegas;
}

HinfResult level_set(Pencil ss, const ReducedModel& a, const ReducedModel* b,
                     const HinfOptions& options) {
  options.validate();
  HinfResult result;
  result.method = kMethod;
  Sigma sigma(a, b);
  // Test frequencies for the first lower bound (Bruinsma-Steinbuch take 0 and the least damped
  // pole's |lambda|): 0 and, for every pole, Im(lambda) and |lambda|. At O(n^2) per evaluation this
  // costs less than one Hamiltonian iteration and usually starts next to the global peak.
  std::vector<double> tests{0.0};
  const auto add_tests = [&](const ReducedModel& model) {
    for (const Complex& z : poles(model)) {
      if (z.imag() > 0.0) tests.push_back(z.imag());
      if (z.imag() >= 0.0) tests.push_back(std::abs(z));
    }
  };
  add_tests(a);
  if (b != nullptr) add_tests(*b);
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
  const double gn = ss.B.norm(), ln = ss.C.norm();
  if (gn > 0.0 && ln > 0.0) {
    const double alpha = std::sqrt(ln / gn);
    ss.B *= alpha;
    ss.C /= alpha;
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
  return level_set(pencil_of(model, "hinf_norm"), model, nullptr, options);
}

HinfResult hinf_error_norm(const ReducedModel& a, const ReducedModel& b,
                           const HinfOptions& options) {
  options.validate();
  detail::require_same_io(a, b, "hinf_error_norm");
  const Pencil pa = pencil_of(a, "hinf_error_norm: first model");
  const Pencil pb = pencil_of(b, "hinf_error_norm: second model");
  const Index na = pa.A.rows(), nb = pb.A.rows();
  Pencil e{Matrix::Zero(na + nb, na + nb), Matrix::Zero(na + nb, na + nb),
           Matrix(na + nb, pa.B.cols()), Matrix(pa.C.rows(), na + nb),
           pa.e_identity && pb.e_identity};
  e.E.topLeftCorner(na, na) = pa.E;
  e.E.bottomRightCorner(nb, nb) = pb.E;
  e.A.topLeftCorner(na, na) = pa.A;
  e.A.bottomRightCorner(nb, nb) = pb.A;
  e.B << pa.B, pb.B;
  e.C << pa.C, -pb.C;
  return level_set(std::move(e), a, &b, options);
}

}  // namespace ecmor
