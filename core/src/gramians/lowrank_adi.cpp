// lowrank_adi.cpp: the low-rank ADI iteration for the generalized Lyapunov equations of a model's
// first-order realisation, in the residual-factor form with real double steps for complex shift
// pairs, projection and heuristic shifts, and the final column compression.
//
// Design notes (why it looks like this):
//  * Real arithmetic wherever the shift is real. FirstOrderView's solves take complex blocks; on
//    a real factorisation a complex block costs two real solves, so the real-shift solves (and
//    the products with A and E) are written here for real blocks, in the same block reduction to
//    P(s) = s^2 M + s D + K that the view documents. Complex shifts use the view's complex solve,
//    one per conjugate pair.
//  * Z grows in a buffer with doubling capacity: appending to an Eigen matrix by
//    conservativeResize copies the whole factor at every step (quadratic in the rank).
//  * Factorisations are cached by their shift for the lifetime of the LowRankAdi, so the
//    observability run (same pencil, transposed solves) and cyclic reuse never refactorise.
//  * Unstable Ritz values: a Ritz value with Re >= 0 is either an eigenvalue of the model (the
//    Gramians do not exist: refused with its name) or an artefact of projecting a non-normal
//    pencil (mirrored, as Benner, Kuerschner and Saak do). The Ritz pair's backward error tells
//    them apart; see AdiOptions::unstable_ritz_residual.
#include "ecmor/gramians/lowrank_adi.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/QR>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <utility>

#include <fmt/format.h>

#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"
#include "base/number_text.hpp"
#include "linalg/qz_solver.hpp"

namespace ecmor {

using detail::number_text;

std::string to_string(GramianSide side) {
  return side == GramianSide::Controllability ? "controllability" : "observability";
}

std::string to_string(AdiShiftStrategy strategy) {
  return strategy == AdiShiftStrategy::Projection ? "projection" : "heuristic";
}

AdiShiftStrategy parse_adi_shift_strategy(const std::string& name) {
  if (name == "projection") return AdiShiftStrategy::Projection;
  if (name == "heuristic") return AdiShiftStrategy::Heuristic;
  throw ConfigError("unknown ADI shift strategy '" + name +
                    "': valid strategies are projection, heuristic");
}

void AdiOptions::validate() const {
  auto fail = [](const std::string& field, const std::string& value, const std::string& rule) {
    throw ConfigError("AdiOptions::" + field + " = " + value + ": " + rule);
  };
  if (!(tolerance > 0.0 && tolerance < 1.0))
    fail("tolerance", number_text(tolerance), "must be in (0, 1)");
  if (max_iterations < 1) fail("max_iterations", std::to_string(max_iterations), "must be >= 1");
  if (max_shifts < 1) fail("max_shifts", std::to_string(max_shifts), "must be >= 1");
  if (projection_columns < 0)
    fail("projection_columns", std::to_string(projection_columns), "must be >= 0");
  if (arnoldi_steps < 1) fail("arnoldi_steps", std::to_string(arnoldi_steps), "must be >= 1");
  if (inverse_arnoldi_steps < 1)
    fail("inverse_arnoldi_steps", std::to_string(inverse_arnoldi_steps), "must be >= 1");
  if (!(unstable_ritz_residual >= 0.0 && unstable_ritz_residual < 1.0))
    fail("unstable_ritz_residual", number_text(unstable_ritz_residual), "must be in [0, 1)");
  if (!(compression_tolerance >= 0.0 && compression_tolerance < 1.0))
    fail("compression_tolerance", number_text(compression_tolerance), "must be in [0, 1)");
}

namespace {

using Clock = std::chrono::steady_clock;

bool all_finite(const Matrix& X) { return X.allFinite(); }
bool all_finite(const ComplexMatrix& X) { return X.allFinite(); }

/// ||X' X||_2 = sigma_max(X)^2 of a tall block with few columns.
double gram_norm(const Matrix& X) {
  if (X.cols() == 0) return 0.0;
  const Matrix G = X.transpose() * X;
  return Eigen::SelfAdjointEigenSolver<Matrix>(G, Eigen::EigenvaluesOnly).eigenvalues().maxCoeff();
}

/// Real-arithmetic operations with the first-order realisation (E, A) of the view's model; with
/// `transposed` they act with E', A' (observability side).
class RealOps {
 public:
  explicit RealOps(FirstOrderView& view) : m_view(view) {}

  Index state_size() const { return m_view.state_size(); }

  Matrix apply_e(const Matrix& X, bool transposed) const {
    return transposed ? m_view.apply_e_transposed(X) : m_view.apply_e(X);
  }

  /// A X (or A' X). Second order: A = [0 I; -K -D], A' = [0 -K'; I -D'].
  Matrix apply_a(const Matrix& X, bool transposed) const {
    const SecondOrderModel* so = m_view.so();
    if (so == nullptr) {
      // The view does not expose A; the solver's combination product -T_0 does (in complex
      // arithmetic, which costs one more real product; only used for small blocks).
      const std::array<Complex, 2> w{Complex(-1.0), Complex(0.0)};
      const ComplexMatrix Xc = X.cast<Complex>();
      const ComplexMatrix Y = transposed ? m_view.solver().apply_combination_transposed(w, Xc)
                                         : m_view.solver().apply_combination(w, Xc);
      return Y.real();
    }
    const Index n = m_view.size();
    const auto x1 = X.topRows(n), x2 = X.bottomRows(n);
    Matrix out(2 * n, X.cols());
    if (!transposed) {
      out.topRows(n) = x2;
      out.bottomRows(n) = -(so->K * x1) - so->D * x2;
    } else {
      out.topRows(n) = -(so->K.transpose() * x2);
      out.bottomRows(n) = x1 - so->D.transpose() * x2;
    }
    return out;
  }

  /// (s E - A)^-1 R (or (s E - A)^-T R) for real s and a real factorisation of P(s).
  Matrix solve(const Factorization& p, double s, const Matrix& R, bool transposed) const {
    const SecondOrderModel* so = m_view.so();
    if (so == nullptr) return transposed ? p.solve_transposed(R) : p.solve(R);
    const Index n = m_view.size();
    const auto f = R.topRows(n), g = R.bottomRows(n);
    Matrix out(2 * n, R.cols());
    if (!transposed) {
      // P(s) x1 = g + (s M + D) f,  x2 = s x1 - f.
      const Matrix rhs = g + s * (so->M * f) + so->D * f;
      const Matrix x1 = p.solve(rhs);
      out.topRows(n) = x1;
      out.bottomRows(n) = s * x1 - f;
    } else {
      // P(s)' y2 = f + s g,  y1 = (s M' + D') y2 - g.
      const Matrix y2 = p.solve_transposed(Matrix(f + s * g));
      out.topRows(n) = s * (so->M.transpose() * y2) + so->D.transpose() * y2 - g;
      out.bottomRows(n) = y2;
    }
    return out;
  }

  /// The same for a complex s (complex factorisation), through the view.
  ComplexMatrix solve(const Factorization& p, Complex s, const Matrix& R, bool transposed) const {
    const ComplexMatrix Rc = R.cast<Complex>();
    return transposed ? m_view.solve_transposed(p, s, Rc) : m_view.solve(p, s, Rc);
  }

  /// E^-1 X (or E^-T X) with a factorisation of E (descriptor) or M (second order:
  /// E = diag(I, M)).
  Matrix solve_e(const Factorization& e, const Matrix& X, bool transposed) const {
    if (m_view.so() == nullptr) return transposed ? e.solve_transposed(X) : e.solve(X);
    const Index n = m_view.size();
    const Matrix x2 = X.bottomRows(n);
    Matrix out(2 * n, X.cols());
    out.topRows(n) = X.topRows(n);
    out.bottomRows(n) = transposed ? e.solve_transposed(x2) : e.solve(x2);
    return out;
  }

 private:
  FirstOrderView& m_view;
};

/// Eigen-decomposition of the Gram matrix X' X (largest first): the right singular vectors and
/// squared singular values of X, by one matrix product instead of a QR of the tall X.
std::pair<Vector, Matrix> gram_eigen(const Matrix& X) {
  Matrix G = Matrix::Zero(X.cols(), X.cols());
  G.selfadjointView<Eigen::Lower>().rankUpdate(X.transpose());
  Eigen::SelfAdjointEigenSolver<Matrix> es(G.selfadjointView<Eigen::Lower>());
  return {es.eigenvalues().reverse(), es.eigenvectors().rowwise().reverse()};
}

/// A basis of the range of X, orthonormal to working accuracy for its well-determined part:
/// U = X V L^-1/2 over the eigenpairs of X' X above k eps lambda_max (directions below that are
/// rounding). The Ritz values are computed from the generalized projected pencil (U'AU, U'EU), so
/// a slight loss of orthogonality does not bias them; the Gram route is one matrix product,
/// where a pivoted QR of the tall block took seconds at N = 2e4.
Matrix range_basis(const Matrix& X) {
  if (X.cols() == 0) return Matrix(X.rows(), 0);
  const auto [lambda, V] = gram_eigen(X);
  const double cut = static_cast<double>(X.cols()) * std::numeric_limits<double>::epsilon() *
                     lambda(0);
  Index r = 0;
  while (r < lambda.size() && lambda(r) > cut) ++r;
  return X * (V.leftCols(r) * lambda.head(r).cwiseSqrt().cwiseInverse().asDiagonal());
}

struct RitzPair {
  Complex value;
  ComplexVector vector;  // in the state space (empty when not needed)
};

/// Penzl's min-max selection (LYAPACK lp_mnmx): from the candidate set R (Re < 0, closed under
/// conjugation, each pair stored once with Im > 0), pick the one minimising the worst ADI
/// contraction max_x |(p - x) / (p + x)| over R, then repeatedly the candidate where the product
/// of the contractions of the shifts chosen so far is largest. A complex candidate counts twice.
std::vector<Complex> select_minmax(const std::vector<Complex>& candidates, Index max_count) {
  std::vector<Complex> all;  // with conjugates, to evaluate the contraction on the whole set
  for (const Complex& c : candidates) {
    all.push_back(c);
    if (c.imag() != 0.0) all.push_back(std::conj(c));
  }
  auto contraction = [](Complex p, Complex x) {
    // |(p - x) / (p + x)| for the pair (p, conj p): the product over both members.
    double v = std::abs((p - x) / (p + x));
    if (p.imag() != 0.0) v *= std::abs((std::conj(p) - x) / (std::conj(p) + x));
    return v;
  };
  std::vector<Complex> chosen;
  std::vector<bool> used(candidates.size(), false);
  Index count = 0;
  if (candidates.empty()) return chosen;
  // First shift: minimise the worst contraction over the whole set.
  std::size_t best = 0;
  double best_value = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    double worst = 0.0;
    for (const Complex& x : all) worst = std::max(worst, contraction(candidates[i], x));
    if (worst < best_value) {
      best_value = worst;
      best = i;
    }
  }
  chosen.push_back(candidates[best]);
  used[best] = true;
  count += candidates[best].imag() != 0.0 ? 2 : 1;
  while (count < max_count) {
    std::optional<std::size_t> next;
    double largest = -1.0;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      if (used[i]) continue;
      double product = 1.0;
      for (const Complex& p : chosen) product *= contraction(p, candidates[i]);
      if (product > largest) {
        largest = product;
        next = i;
      }
    }
    if (!next) break;
    chosen.push_back(candidates[*next]);
    used[*next] = true;
    count += candidates[*next].imag() != 0.0 ? 2 : 1;
  }
  return chosen;
}

/// ||W S W'||_2 for a tall W with few columns and a symmetric S: the nonzero eigenvalues of
/// W S W' are those of R S R' for the thin QR W = Q R. O(n k^2) for k columns, small next to a
/// solve with the same block.
double ldl_norm(const Matrix& W, const Matrix& S) {
  if (W.cols() == 0) return 0.0;
  const Eigen::HouseholderQR<Matrix> qr(W);
  const Index k = std::min(W.rows(), W.cols());
  const Matrix R = qr.matrixQR().topRows(k).triangularView<Eigen::Upper>();
  const Matrix T = R * S * R.transpose();
  const Vector ev = Eigen::SelfAdjointEigenSolver<Matrix>(Matrix((T + T.transpose()) / 2),
                                                          Eigen::EigenvaluesOnly)
                        .eigenvalues();
  return std::max(std::abs(ev.minCoeff()), std::abs(ev.maxCoeff()));
}

/// The rules for an indefinite right-hand side G S G' (see LowRankAdi::solve(side, G, S)).
void check_ldl_rhs(const std::string& where, Index n, const Matrix& G, const Matrix& S) {
  auto dims = [](const Matrix& X) {
    return std::to_string(X.rows()) + " x " + std::to_string(X.cols());
  };
  if (G.rows() != n || G.cols() == 0)
    throw InputError(where + ": G is " + dims(G) + ": must have the state size " +
                     std::to_string(n) + " rows and at least one column");
  if (S.rows() != G.cols() || S.cols() != G.cols())
    throw InputError(where + ": S is " + dims(S) + ": must be square of G's column count " +
                     std::to_string(G.cols()));
  if (!G.allFinite()) throw InputError(where + ": G has a non-finite entry");
  if (!S.allFinite()) throw InputError(where + ": S has a non-finite entry");
  const double asym = (S - S.transpose()).norm();
  if (asym > 1e-12 * S.norm())
    throw InputError(where + ": S is not symmetric: ||S - S'||_F = " + number_text(asym) +
                     " > 1e-12 ||S||_F");
}

/// Fills the timing and solver-work fields at the end of a run.
void record_work(FirstOrderView& view, const SolverCounters& c0, Clock::time_point t0,
                 AdiResult& result) {
  const SolverCounters dc = view.solver().counters() - c0;
  result.counters = dc;
  result.factorizations = dc.factorizations;
  result.solves = dc.solves;
  result.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
}

/// A semidefinite factor Z of X = L D L', D = diag(S, ..., S), into result.Z, and the truncation
/// diagnostics. Householder QR L = Q R, then R D R' = Y Theta Y' and Z = Q Y_+ Theta_+^1/2 over
/// the kept eigenvalues (> tol^2 theta_max with compression, > 0 without).
/// Why not the Gram route of the plain compression: with an indefinite D the directions of L
/// with small singular values sigma_j enter X through cross terms sigma_1 sigma_j, and the Gram
/// route, which must drop the directions below sqrt(k eps) sigma_1 (their singular vectors are
/// lost in rounding), would change X by about sqrt(k eps) ||X|| = 1e-7 ||X||. The QR is backward
/// stable: Q R = L + dL with ||dL|| ~ eps ||L||, so R D R' represents X to eps ||L||^2.
void semidefinite_factor(const Matrix& L, const Matrix& S, const AdiOptions& opt,
                         AdiLdlResult& result) {
  const Index n = L.rows(), cols = L.cols(), m = S.rows();
  if (cols == 0) {
    result.Z = Matrix(n, 0);
    return;
  }
  const Eigen::HouseholderQR<Matrix> qr(L);
  const Index k = std::min(n, cols);
  const Matrix R = qr.matrixQR().topRows(k).triangularView<Eigen::Upper>();
  Matrix RD(k, cols);
  for (Index j = 0; j < cols; j += m) RD.middleCols(j, m).noalias() = R.middleCols(j, m) * S;
  Matrix T = RD * R.transpose();
  T = ((T + T.transpose()) / 2).eval();
  const Eigen::SelfAdjointEigenSolver<Matrix> es(T);  // ascending eigenvalues
  const Vector& theta = es.eigenvalues();
  const double theta_max = theta(k - 1), theta_min = theta(0);
  const double scale = std::max(std::abs(theta_max), std::abs(theta_min));
  result.largest_eigenvalue = theta_max;
  result.negative_eigenvalues = (theta.array() < 0.0).count();
  result.most_negative_eigenvalue = theta_min < 0.0 && scale > 0.0 ? theta_min / scale : 0.0;
  const double cut =
      theta_max > 0.0 && opt.compress
          ? opt.compression_tolerance * opt.compression_tolerance * theta_max
          : 0.0;
  Index keep = 0;
  while (keep < k && theta(k - 1 - keep) > cut) ++keep;
  if (keep < k && theta(k - 1 - keep) > 0.0 && theta_max > 0.0)
    result.largest_dropped_positive = theta(k - 1 - keep) / theta_max;
  // Columns in descending order of the eigenvalue, as the plain compression returns them.
  Matrix Y = Matrix::Zero(n, keep);
  for (Index j = 0; j < keep; ++j)
    Y.col(j).head(k) = es.eigenvectors().col(k - 1 - j) * std::sqrt(theta(k - 1 - j));
  result.Z = qr.householderQ() * Y;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

struct LowRankAdi::Impl {
  Impl(FirstOrderView& v, const AdiOptions& o) : view(v), ops(v), options(o) {}

  FirstOrderView& view;
  RealOps ops;
  const AdiOptions& options;
  /// Factorisations of P(s) by s = -p.
  std::map<std::pair<double, double>, std::shared_ptr<const Factorization>> factorizations;
  std::shared_ptr<const Factorization> e_factorization;  // E (descriptor) or M (second order)
  std::optional<std::vector<Complex>> heuristic_shifts;   // same for both sides (same spectrum)

  const char* e_name() const { return view.second_order() ? "M" : "E"; }

  /// Factorises E (M) once: a singular one means a DAE, which the ADI Gramians do not cover.
  void check_e() {
    if (e_factorization) return;
    std::vector<Complex> w(view.second_order() ? 3 : 2, Complex(0.0));
    w.back() = 1.0;
    try {
      e_factorization = view.solver().factorize_combination(w);
    } catch (const NumericalError& e) {
      throw InputError(std::string("low-rank ADI: ") + e_name() +
                       " is singular (" + e.what() +
                       "): a DAE (singular E) is not supported; the Gramians of the first-order "
                       "realisation need a nonsingular " + e_name());
    }
  }

  std::shared_ptr<const Factorization> factorization(Complex p, Index iteration) {
    const Complex s = -p;
    const auto key = std::make_pair(s.real(), s.imag());
    auto it = factorizations.find(key);
    if (it != factorizations.end()) return it->second;
    std::shared_ptr<const Factorization> f;
    try {
      f = view.solver().factorize(s);
    } catch (const NumericalError& e) {
      throw NumericalError("low-rank ADI: breakdown at iteration " + std::to_string(iteration) +
                           ": A + p E is singular for the shift p = " + number_text(p) + " (" +
                           e.what() + ")");
    }
    factorizations.emplace(key, f);
    return f;
  }

  /// Relative backward error of a Ritz pair: ||A u - theta E u|| / (||A u|| + |theta| ||E u||).
  double ritz_residual(const RitzPair& r, bool transposed) const {
    const Matrix ur = r.vector.real(), ui = r.vector.imag();
    Matrix U(ur.rows(), 2);
    U.col(0) = ur;
    U.col(1) = ui;
    const Matrix AU = ops.apply_a(U, transposed), EU = ops.apply_e(U, transposed);
    const ComplexVector Au = AU.col(0).cast<Complex>() + Complex(0, 1) * AU.col(1).cast<Complex>();
    const ComplexVector Eu = EU.col(0).cast<Complex>() + Complex(0, 1) * EU.col(1).cast<Complex>();
    const double denom = Au.norm() + std::abs(r.value) * Eu.norm();
    return denom > 0.0 ? (Au - r.value * Eu).norm() / denom : 1.0;
  }

  /// Ritz values with Re >= 0: refuse the model if one is an eigenvalue, else mirror or drop.
  /// Returns the admissible shift candidates (Re < 0, each conjugate pair once with Im > 0).
  std::vector<Complex> admissible(const std::vector<RitzPair>& ritz, bool transposed,
                                  const char* where, AdiResult& result) const {
    std::vector<Complex> out;
    for (const RitzPair& r : ritz) {
      Complex theta = r.value;
      if (!std::isfinite(theta.real()) || !std::isfinite(theta.imag()) || theta == Complex(0.0))
        continue;  // infinite (singular projected E) or zero: no usable shift
      if (theta.imag() < 0.0) continue;  // the conjugate partner carries the pair
      if (theta.real() >= 0.0) {
        const double rho = r.vector.size() > 0 ? ritz_residual(r, transposed) : 1.0;
        // The pair is an exact eigenpair of a pencil within relative distance rho; for a
        // normal pencil the eigenvalue is then within about 2 rho |theta| of theta, so an
        // unstable eigenvalue is certain when Re theta exceeds that.
        if (rho <= options.unstable_ritz_residual && theta.real() > 2.0 * rho * std::abs(theta)) {
          throw InputError("low-rank ADI (" + to_string(result.side) +
                           "): the model is not asymptotically stable: the pencil (A, E) has the "
                           "eigenvalue " + number_text(theta) + " with Re >= 0 (" + where +
                           " Ritz value, relative residual " + number_text(rho) +
                           "); the Gramians do not exist");
        }
        ++result.mirrored_ritz_values;
        theta = Complex(-theta.real(), theta.imag());
        if (theta.real() == 0.0) continue;  // on the imaginary axis: cannot be mirrored
      }
      // Real arithmetic rounding leaves tiny imaginary parts on real Ritz values of symmetric
      // problems solved by QZ; a pair that close to the real axis is treated as real.
      if (std::abs(theta.imag()) <= 1e-12 * std::abs(theta)) theta = Complex(theta.real(), 0.0);
      out.push_back(theta);
    }
    return out;
  }

  /// Ritz pairs of the pencil (A, E) (or (A', E')) projected on span(X).
  std::vector<RitzPair> projected_ritz(const Matrix& X, bool transposed) const {
    const Matrix U = range_basis(X);
    std::vector<RitzPair> out;
    if (U.cols() == 0) return out;
    const Matrix Ar = U.transpose() * ops.apply_a(U, transposed);
    const Matrix Er = U.transpose() * ops.apply_e(U, transposed);
    const double asym_a = (Ar - Ar.transpose()).norm(), asym_e = (Er - Er.transpose()).norm();
    if (asym_a <= 1e-12 * Ar.norm() && asym_e <= 1e-12 * Er.norm()) {
      // Symmetric A, SPD E (rail): real Ritz values from the symmetric-definite solver.
      const Matrix As = (Ar + Ar.transpose()) / 2, Es = (Er + Er.transpose()) / 2;
      Eigen::LLT<Matrix> llt(Es);
      if (llt.info() == Eigen::Success) {
        Eigen::GeneralizedSelfAdjointEigenSolver<Matrix> ges(As, Es);
        if (ges.info() == Eigen::Success) {
          // The Ritz vector is only needed to judge a Ritz value with Re >= 0 (admissible()).
          for (Index i = 0; i < U.cols(); ++i) {
            const double theta = ges.eigenvalues()(i);
            ComplexVector u;
            if (theta >= 0.0) u = (U * ges.eigenvectors().col(i)).cast<Complex>();
            out.push_back({Complex(theta, 0.0), std::move(u)});
          }
          return out;
        }
      }
    }
    detail::QzSolver qz(Ar, Er, true);
    if (!qz.converged()) return out;
    for (Index i = 0; i < U.cols(); ++i) {
      const Complex alpha = qz.alphas()(i);
      const double beta = qz.betas()(i);
      if (beta == 0.0) continue;
      // The Ritz vector (an N-vector) only where admissible() needs it, Re theta >= 0: forming
      // it for every Ritz value was O(N k^2) complex work per shift set, a third of the ADI time
      // on the triple chain.
      const Complex theta = alpha / beta;
      ComplexVector u;
      if (theta.real() >= 0.0) {
        const ComplexVector y = qz.eigenvectors().col(i);
        u = (U * y.real()).cast<Complex>() + Complex(0.0, 1.0) * (U * y.imag()).cast<Complex>();
      }
      out.push_back({theta, std::move(u)});
    }
    return out;
  }

  /// Arnoldi on op with `steps` steps from the normalised start vector; Ritz pairs of op.
  template <class Op>
  std::vector<RitzPair> arnoldi(const Op& op, Index steps, const char* what) const {
    const Index n = ops.state_size();
    steps = std::min(steps, n);
    Matrix V = Matrix::Zero(n, steps + 1);
    Matrix H = Matrix::Zero(steps + 1, steps);
    V.col(0) = Vector::Ones(n) / std::sqrt(static_cast<double>(n));
    Index k = 0;
    for (; k < steps; ++k) {
      Vector w = op(Matrix(V.col(k)));
      if (!w.allFinite())
        throw NumericalError(std::string("low-rank ADI heuristic shifts: Arnoldi on ") + what +
                             " produced a non-finite vector at step " + std::to_string(k + 1));
      // Classical Gram-Schmidt twice: orthogonal to working precision.
      for (int pass = 0; pass < 2; ++pass) {
        const Vector h = V.leftCols(k + 1).transpose() * w;
        w -= V.leftCols(k + 1) * h;
        H.col(k).head(k + 1) += h;
      }
      const double beta = w.norm();
      H(k + 1, k) = beta;
      if (beta <= 1e-14 * H.col(k).norm()) {  // invariant subspace found
        ++k;
        break;
      }
      V.col(k + 1) = w / beta;
    }
    std::vector<RitzPair> out;
    if (k == 0) return out;
    Eigen::EigenSolver<Matrix> es(H.topLeftCorner(k, k), true);
    if (es.info() != Eigen::Success) return out;
    for (Index i = 0; i < k; ++i)
      out.push_back({es.eigenvalues()(i), V.leftCols(k).cast<Complex>() * es.eigenvectors().col(i)});
    return out;
  }

  /// Penzl's heuristic set: Ritz values of E^-1 A and reciprocals of those of A^-1 E.
  std::vector<Complex> heuristic(bool transposed, AdiResult& result) {
    if (heuristic_shifts) return *heuristic_shifts;
    // The spectra of (A, E) and (A', E') agree, so one set serves both sides; Arnoldi is run on
    // the non-transposed pencil.
    (void)transposed;
    const Factorization& e = *e_factorization;
    auto op_plus = [&](const Matrix& x) -> Vector {
      return ops.solve_e(e, ops.apply_a(x, false), false).col(0);
    };
    std::shared_ptr<const Factorization> p0;
    try {
      p0 = view.solver().factorize(Complex(0.0));
    } catch (const NumericalError& err) {
      throw NumericalError(std::string("low-rank ADI heuristic shifts: A is singular (") +
                           err.what() + "): Arnoldi on A^-1 E is impossible; use projection "
                           "shifts");
    }
    auto op_minus = [&](const Matrix& x) -> Vector {
      // A^-1 = -(0 E - A)^-1.
      return (-ops.solve(*p0, 0.0, ops.apply_e(x, false), false)).col(0);
    };
    std::vector<RitzPair> ritz = arnoldi(op_plus, options.arnoldi_steps, "E^-1 A");
    for (RitzPair& r : arnoldi(op_minus, options.inverse_arnoldi_steps, "A^-1 E")) {
      if (r.value == Complex(0.0)) continue;
      r.value = 1.0 / r.value;
      ritz.push_back(std::move(r));
    }
    const std::vector<Complex> candidates = admissible(ritz, false, "heuristic (Arnoldi)", result);
    heuristic_shifts = select_minmax(candidates, options.max_shifts);
    return *heuristic_shifts;
  }

  /// The ADI iteration from W_0 = W with the residual W_k S W_k' (S == nullptr: S = I, the plain
  /// equation); rhs_norm = ||W_0 S W_0'||_2 > 0. Returns the uncompressed factor (X_k = L S~ L',
  /// S~ = diag(S, ..., S)) and fills the iteration fields of `result` (residuals, steps, shifts,
  /// shift_sets, iterations, residual, converged, message).
  Matrix iterate(GramianSide side, Matrix W, const Matrix* S, double rhs_norm,
                 AdiResult& result) {
    const bool tr = side == GramianSide::Observability;
    const Index n = ops.state_size();
    // Z in a buffer with doubling capacity (see the file comment).
    Matrix Zbuf(n, std::max<Index>(4 * W.cols(), 16));
    Index cols = 0;
    auto append = [&](const Matrix& block) {
      if (cols + block.cols() > Zbuf.cols()) {
        Matrix bigger(n, std::max(2 * Zbuf.cols(), cols + block.cols()));
        bigger.leftCols(cols) = Zbuf.leftCols(cols);
        Zbuf.swap(bigger);
      }
      Zbuf.middleCols(cols, block.cols()) = block;
      cols += block.cols();
    };

    std::vector<Complex> set;
    std::size_t pos = 0;
    Index cols_at_last_set = 0;
    const Index proj_cols =
        options.projection_columns > 0 ? options.projection_columns : options.max_shifts * W.cols();
    auto new_set = [&]() -> bool {
      std::vector<Complex> fresh;
      if (options.shifts == AdiShiftStrategy::Heuristic) {
        fresh = heuristic(tr, result);
      } else {
        // Project on span(B, E^-1 A B) at the start, then on the columns added since the last set (at
        // most proj_cols of the last ones; at least the last block, so the set never starves).
        Matrix X;
        if (cols == 0) {
          // span(B) alone can hold no information on the spectrum (a position output C' = [c; 0]
          // of a second-order model gives the single Ritz value 0): one Krylov step with E^-1 A
          // (the E factorisation exists already) makes the first set informative.
          X.resize(n, 2 * W.cols());
          X.leftCols(W.cols()) = W;
          X.rightCols(W.cols()) = ops.solve_e(*e_factorization, ops.apply_a(W, tr), tr);
        } else {
          const Index take = std::min(cols, std::max(cols - cols_at_last_set, proj_cols));
          X = Zbuf.middleCols(cols - take, take);
        }
        const std::vector<RitzPair> ritz = projected_ritz(X, tr);
        fresh = select_minmax(admissible(ritz, tr, "projection", result), options.max_shifts);
      }
      cols_at_last_set = cols;
      if (fresh.empty()) return false;
      set = std::move(fresh);
      pos = 0;
      ++result.shift_sets;
      return true;
    };
    if (!new_set()) {
      throw NumericalError("low-rank ADI (" + to_string(side) + "): no admissible shift: every "
                           "Ritz value of the initial " + to_string(options.shifts) +
                           " shift set is infinite, zero or on the imaginary axis (" +
                           std::to_string(result.mirrored_ritz_values) +
                           " had Re >= 0); an undamped model?");
    }

    double res = 1.0;
    while (result.iterations < options.max_iterations && res > options.tolerance) {
      check_interrupt(fmt::format("low-rank ADI, iteration {}", result.iterations + 1));
      if (pos == set.size()) {
        // Shifts used up: a fresh projection set, or cyclic reuse (heuristic, or a projection
        // that found no admissible Ritz value).
        if (options.shifts == AdiShiftStrategy::Heuristic || !new_set()) pos = 0;
      }
      const Complex p = set[pos++];
      const Index it = result.iterations + 1;
      if (!(p.real() < 0.0))
        throw NumericalError("low-rank ADI: shift p = " + number_text(p) + " at iteration " +
                             std::to_string(it) + " is not in the open left half-plane");
      const auto fact = factorization(p, it);
      if (p.imag() == 0.0) {
        // (A + p E) V = W:  V = -(s E - A)^-1 W at s = -p.
        const Matrix V = -ops.solve(*fact, -p.real(), W, tr);
        if (!all_finite(V))
          throw NumericalError("low-rank ADI: breakdown at iteration " + std::to_string(it) +
                               ": the solve with the shift p = " + number_text(p) +
                               " returned a non-finite value");
        W -= (2.0 * p.real()) * ops.apply_e(V, tr);
        append(std::sqrt(-2.0 * p.real()) * V);
        result.iterations += 1;
        result.shifts.push_back(p);
      } else {
        const ComplexMatrix V = -ops.solve(*fact, -p, W, tr);
        if (!all_finite(V))
          throw NumericalError("low-rank ADI: breakdown at iteration " + std::to_string(it) +
                               ": the solve with the shift p = " + number_text(p) +
                               " returned a non-finite value");
        // The real double step (Benner, Kuerschner, Saak 2013, Alg. 3).
        const double gamma = 2.0 * std::sqrt(-p.real());
        const double delta = p.real() / p.imag();
        const Matrix Vr = V.real(), Vi = V.imag();
        const Matrix Vc = Vr + delta * Vi;
        W += (gamma * gamma) * ops.apply_e(Vc, tr);
        Matrix block(n, 2 * V.cols());
        block.leftCols(V.cols()) = gamma * Vc;
        block.rightCols(V.cols()) = (gamma * std::sqrt(delta * delta + 1.0)) * Vi;
        append(block);
        result.iterations += 2;
        result.shifts.push_back(p);
        result.shifts.push_back(std::conj(p));
      }
      if (!all_finite(W))
        throw NumericalError("low-rank ADI: breakdown at iteration " + std::to_string(it) +
                             ": the residual factor is not finite after the shift p = " +
                             number_text(p));
      res = (S != nullptr ? ldl_norm(W, *S) : gram_norm(W)) / rhs_norm;
      result.residuals.push_back(res);
      result.steps.push_back({p, res, cols});
    }
    result.residual = res;
    result.converged = res <= options.tolerance;
    result.message =
        std::string(result.converged ? "converged" : "not converged") + ": residual " +
        number_text(res) + (result.converged ? " <= " : " > ") + number_text(options.tolerance) +
        " after " + std::to_string(result.iterations) + " iterations (rank " + std::to_string(cols) +
        (result.converged ? ")" : ", max_iterations reached)");
    if (result.mirrored_ritz_values > 0)
      result.message += "; " + std::to_string(result.mirrored_ritz_values) +
                        " Ritz values with Re >= 0 were mirrored";
    return Matrix(Zbuf.leftCols(cols));
  }
};

LowRankAdi::LowRankAdi(FirstOrderView& view, const AdiOptions& options) : m_options(options) {
  m_options.validate();
  m_impl = std::make_unique<Impl>(view, m_options);
}

LowRankAdi::~LowRankAdi() = default;

Index LowRankAdi::cached_factorizations() const {
  return static_cast<Index>(m_impl->factorizations.size());
}

void LowRankAdi::clear_cache() { m_impl->factorizations.clear(); }

AdiResult LowRankAdi::solve(GramianSide side) {
  Impl& im = *m_impl;
  const AdiOptions& opt = m_options;
  const auto t0 = Clock::now();
  const SolverCounters c0 = im.view.solver().counters();
  const bool tr = side == GramianSide::Observability;
  const Index n = im.ops.state_size();

  AdiResult result;
  result.side = side;
  im.check_e();

  Matrix W = tr ? Matrix(im.view.output_matrix().transpose()) : im.view.input_matrix();
  const double rhs_norm = gram_norm(W);
  result.residuals.push_back(1.0);
  Matrix Z;
  if (!(rhs_norm > 0.0)) {
    // B = 0 (C = 0): X = 0 solves the equation exactly.
    result.residual = 0.0;
    result.residuals.back() = 0.0;
    result.converged = true;
    result.message = "converged: the right-hand side " + std::string(tr ? "C' C" : "B B'") +
                     " is zero, the Gramian is 0";
    Z = Matrix(n, 0);
  } else {
    Z = im.iterate(side, std::move(W), nullptr, rhs_norm, result);
  }
  result.uncompressed_rank = Z.cols();
  if (opt.compress && Z.cols() > 0) {
    // With Z' Z = V L V' (eigenvalues descending), Z V = U S holds the singular directions.
    // Keeping the columns with lambda_i > tol^2 lambda_1 changes Z Z' by Z V_rest V_rest' Z',
    // whose norm is the largest dropped lambda: <= tol^2 ||Z Z'|| plus the eigensolver's
    // rounding (eps ||Z' Z||). This is as sharp as a QR + SVD of Z at this tolerance and costs
    // two matrix products instead of a Householder QR of the tall Z (seconds at N = 2e4).
    const auto [lambda, V] = gram_eigen(Z);
    const double cut = opt.compression_tolerance * opt.compression_tolerance * lambda(0);
    Index keep = 0;
    while (keep < lambda.size() && lambda(keep) > cut) ++keep;
    Z = Z * V.leftCols(keep);
  }
  result.Z = std::move(Z);
  record_work(im.view, c0, t0, result);
  return result;
}

AdiLdlResult LowRankAdi::solve(GramianSide side, const Matrix& G, const Matrix& S) {
  Impl& im = *m_impl;
  const AdiOptions& opt = m_options;
  const auto t0 = Clock::now();
  const SolverCounters c0 = im.view.solver().counters();
  const Index n = im.ops.state_size();
  check_ldl_rhs("LowRankAdi::solve", n, G, S);

  AdiLdlResult result;
  result.side = side;
  result.G = G;
  // Exactly symmetric (the check allowed rounding), so that R S R' is symmetric up to its own
  // rounding only.
  result.S = (S + S.transpose()) / 2;
  im.check_e();

  const double rhs_norm = ldl_norm(G, result.S);
  result.rhs_norm = rhs_norm;
  result.residuals.push_back(1.0);
  Matrix L;
  if (!(rhs_norm > 0.0)) {
    result.residual = 0.0;
    result.residuals.back() = 0.0;
    result.converged = true;
    result.message = "converged: the right-hand side G S G' is zero, the solution is 0";
    L = Matrix(n, 0);
  } else {
    L = im.iterate(side, G, &result.S, rhs_norm, result);
  }
  result.uncompressed_rank = L.cols();
  result.blocks = L.cols() / G.cols();
  semidefinite_factor(L, result.S, opt, result);
  result.message += "; semidefinite factor of rank " + std::to_string(result.Z.cols()) +
                    ", most negative eigenvalue dropped " +
                    number_text(result.most_negative_eigenvalue) + " of the largest";
  result.L = std::move(L);
  record_work(im.view, c0, t0, result);
  return result;
}

LowRankGramians lowrank_gramians(FirstOrderView& view, const AdiOptions& options) {
  LowRankAdi adi(view, options);
  LowRankGramians g;
  g.controllability = adi.solve(GramianSide::Controllability);
  g.observability = adi.solve(GramianSide::Observability);
  return g;
}

namespace {

/// ||A Z Z' E' + E Z Z' A' + G S G'||_2 / ||G S G'||_2 (S == nullptr: S = I), see
/// lowrank_residual. With F = [A Z, E Z, G] the residual is F S_F F' with
/// S_F = [0 I 0; I 0 0; 0 0 S]; its nonzero eigenvalues are those of R S_F R' (F = Q R).
double residual_of(FirstOrderView& view, const Matrix& Z, GramianSide side, const Matrix& G,
                   const Matrix* S) {
  const bool tr = side == GramianSide::Observability;
  const Index n = view.state_size();
  RealOps ops(view);
  const double rhs = S != nullptr ? ldl_norm(G, *S) : gram_norm(G);
  const Index r = Z.cols(), m = G.cols();
  Matrix F(n, 2 * r + m);
  F.leftCols(r) = ops.apply_a(Z, tr);
  F.middleCols(r, r) = ops.apply_e(Z, tr);
  F.rightCols(m) = G;
  const Index k = F.cols();
  Eigen::HouseholderQR<Matrix> qr(F);
  const Index kk = std::min(n, k);
  const Matrix R = qr.matrixQR().topRows(kk).triangularView<Eigen::Upper>();
  Matrix RS(kk, k);
  RS.leftCols(r) = R.middleCols(r, r);
  RS.middleCols(r, r) = R.leftCols(r);
  RS.rightCols(m) = S != nullptr ? Matrix(R.rightCols(m) * *S) : Matrix(R.rightCols(m));
  const Matrix T = RS * R.transpose();
  const Matrix Ts = (T + T.transpose()) / 2;
  const Vector ev =
      Eigen::SelfAdjointEigenSolver<Matrix>(Ts, Eigen::EigenvaluesOnly).eigenvalues();
  const double norm = std::max(std::abs(ev.minCoeff()), std::abs(ev.maxCoeff()));
  return rhs > 0.0 ? norm / rhs : norm;
}

void check_factor_rows(const Matrix& Z, Index n) {
  if (Z.rows() != n)
    throw InputError("lowrank_residual: Z has " + std::to_string(Z.rows()) +
                     " rows: must equal the state size " + std::to_string(n));
}

/// [a X, Y / a] with ||a X||_F = ||Y / a||_F (see lowrank_band_gramians); X, Y unscaled when
/// either is zero.
Matrix balanced_pair(const Matrix& X, const Matrix& Y) {
  const double nx = X.norm(), ny = Y.norm();
  const double a = nx > 0.0 && ny > 0.0 ? std::sqrt(ny / nx) : 1.0;
  Matrix G(X.rows(), X.cols() + Y.cols());
  G.leftCols(X.cols()) = a * X;
  G.rightCols(Y.cols()) = Y / a;
  return G;
}

/// S = [0 I; I 0] with k x k blocks.
Matrix swap_weight(Index k) {
  Matrix S = Matrix::Zero(2 * k, 2 * k);
  S.topRightCorner(k, k).setIdentity();
  S.bottomLeftCorner(k, k).setIdentity();
  return S;
}

}  // namespace

double lowrank_residual(FirstOrderView& view, const Matrix& Z, GramianSide side) {
  check_factor_rows(Z, view.state_size());
  const Matrix B = side == GramianSide::Observability ? Matrix(view.output_matrix().transpose())
                                                      : view.input_matrix();
  return residual_of(view, Z, side, B, nullptr);
}

double lowrank_residual(FirstOrderView& view, const Matrix& Z, GramianSide side, const Matrix& G,
                        const Matrix& S) {
  check_factor_rows(Z, view.state_size());
  check_ldl_rhs("lowrank_residual", view.state_size(), G, S);
  return residual_of(view, Z, side, G, &S);
}

LowRankBandGramians lowrank_band_gramians(FirstOrderView& view, const Band& band,
                                          const AdiOptions& options,
                                          const AdaptiveQuadratureOptions& quadrature) {
  const auto t0 = Clock::now();
  band.validate();
  options.validate();
  quadrature.validate();
  LowRankBandGramians out;
  // L_B = int_Omega (iwE - A)^-1 B dw, L_C = int_Omega (iwE - A)^-T C' dw; the equations need
  // them divided by 2 pi (file comment of the header).
  out.integrals = band_resolvent_integrals(view, band, quadrature);
  out.quadrature_seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  LowRankAdi adi(view, options);
  const Matrix E_Lb = view.apply_e(Matrix(out.integrals.input / kTwoPi));
  out.controllability = adi.solve(GramianSide::Controllability,
                                  balanced_pair(E_Lb, view.input_matrix()),
                                  swap_weight(view.inputs()));
  const Matrix Et_Lc = view.apply_e_transposed(Matrix(out.integrals.output / kTwoPi));
  out.observability = adi.solve(GramianSide::Observability,
                                balanced_pair(Et_Lc, Matrix(view.output_matrix().transpose())),
                                swap_weight(view.outputs()));
  const MatrixQuadrature& q = out.integrals.quadrature;
  if (!q.converged) {
    // Missing the quadrature tolerance is a result, not an exception, but the Gramians are then
    // those of an inaccurate right-hand side: say so where the ADI outcome is read.
    const std::string note = "; the band quadrature did not converge (error estimate " +
                             number_text(q.error_estimate / std::max(q.integral.norm(), 1e-300)) +
                             " relative after " + std::to_string(q.evaluations) +
                             " evaluations): Lb, Lc and hence the Gramians are inaccurate";
    out.controllability.message += note;
    out.observability.message += note;
  }
  out.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return out;
}

}  // namespace ecmor
