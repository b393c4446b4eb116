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

#include <fmt/format.h>

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

#include "base/number_text.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"
#include "gramians/adi_ops.hpp"
#include "gramians/adi_shifts.hpp"

namespace ecmor {

using detail::AdiRealOps;
using detail::AdiShiftSource;
using detail::gram_eigen;
using detail::gram_norm;
using detail::ldl_norm;
using detail::number_text;

std::string to_string(GramianSide side) {
  return side == GramianSide::Controllability ? "controllability" : "observability";
}

namespace {

using Clock = std::chrono::steady_clock;

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
  const double cut = theta_max > 0.0 && opt.compress
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

/// The factor Z in a buffer with doubling capacity (see the file comment).
class GrowingFactor {
 public:
  GrowingFactor(Index rows, Index capacity) : m_buffer(rows, capacity) {}

  Index cols() const { return m_cols; }
  /// The last `count` columns.
  auto last(Index count) const { return m_buffer.middleCols(m_cols - count, count); }

  void append(const Matrix& block) {
    if (m_cols + block.cols() > m_buffer.cols()) {
      Matrix bigger(m_buffer.rows(), std::max(2 * m_buffer.cols(), m_cols + block.cols()));
      bigger.leftCols(m_cols) = m_buffer.leftCols(m_cols);
      m_buffer.swap(bigger);
    }
    m_buffer.middleCols(m_cols, block.cols()) = block;
    m_cols += block.cols();
  }

  Matrix take() { return Matrix(m_buffer.leftCols(m_cols)); }

 private:
  Matrix m_buffer;
  Index m_cols = 0;
};

}  // namespace

// ---------------------------------------------------------------------------------------------

struct LowRankAdi::Impl {
  Impl(FirstOrderView& v, const AdiOptions& o) : view(v), ops(v), options(o), shifts(v, ops, o) {}

  FirstOrderView& view;
  AdiRealOps ops;
  const AdiOptions& options;
  AdiShiftSource shifts;
  /// Factorisations of P(s) by s = -p.
  std::map<std::pair<double, double>, std::shared_ptr<const Factorization>> factorizations;
  std::shared_ptr<const Factorization> e_factorization;  // E (descriptor) or M (second order)

  const char* e_name() const { return view.second_order() ? "M" : "E"; }

  /// Factorises E (M) once: a singular one means a DAE, which the ADI Gramians do not cover.
  void check_e() {
    if (e_factorization) return;
    std::vector<Complex> w(view.second_order() ? 3 : 2, Complex(0.0));
    w.back() = 1.0;
    try {
      e_factorization = view.solver().factorize_combination(w);
    } catch (const NumericalError& e) {
      throw InputError(std::string("low-rank ADI: ") + e_name() + " is singular (" + e.what() +
                       "): a DAE (singular E) is not supported; the Gramians of the first-order "
                       "realisation need a nonsingular " +
                       e_name());
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

  /// The current shift set and the rule for the next one: a fresh projection set when the
  /// shifts are used up (projected on span(B, E^-1 A B) at the start, then on the columns added
  /// since the last set, at least the last `projection_columns`), or cyclic reuse (heuristic
  /// shifts, or a projection that found no admissible Ritz value).
  class ShiftQueue {
   public:
    ShiftQueue(Impl& impl, bool tr, const Matrix& W0, AdiResult& result)
        : m_impl(impl), m_tr(tr), m_w0(W0), m_result(result) {
      const AdiOptions& o = impl.options;
      m_projection_cols =
          o.projection_columns > 0 ? o.projection_columns : o.max_shifts * W0.cols();
    }

    /// A new set into the queue; false (queue unchanged) when no shift is admissible.
    bool refill(const GrowingFactor& Z) {
      std::vector<Complex> fresh;
      if (m_impl.options.shifts == AdiShiftStrategy::Heuristic) {
        fresh = m_impl.shifts.heuristic(*m_impl.e_factorization, m_result);
      } else {
        fresh = m_impl.shifts.projection(projection_space(Z), m_tr, m_result);
      }
      m_cols_at_last_set = Z.cols();
      if (fresh.empty()) return false;
      m_set = std::move(fresh);
      m_pos = 0;
      ++m_result.shift_sets;
      return true;
    }

    Complex next(const GrowingFactor& Z) {
      if (m_pos == m_set.size()) {
        if (m_impl.options.shifts == AdiShiftStrategy::Heuristic || !refill(Z)) m_pos = 0;
      }
      return m_set[m_pos++];
    }

   private:
    Matrix projection_space(const GrowingFactor& Z) const {
      if (Z.cols() == 0) {
        // span(B) alone can hold no information on the spectrum (a position output C' = [c; 0]
        // of a second-order model gives the single Ritz value 0): one Krylov step with E^-1 A
        // (the E factorisation exists already) makes the first set informative.
        Matrix X(m_w0.rows(), 2 * m_w0.cols());
        X.leftCols(m_w0.cols()) = m_w0;
        X.rightCols(m_w0.cols()) =
            m_impl.ops.solve_e(*m_impl.e_factorization, m_impl.ops.apply_a(m_w0, m_tr), m_tr);
        return X;
      }
      const Index take =
          std::min(Z.cols(), std::max(Z.cols() - m_cols_at_last_set, m_projection_cols));
      return Z.last(take);
    }

    Impl& m_impl;
    bool m_tr;
    Matrix m_w0;
    AdiResult& m_result;
    Index m_projection_cols = 0;
    Index m_cols_at_last_set = 0;
    std::vector<Complex> m_set;
    std::size_t m_pos = 0;
  };

  /// One ADI step with the shift p (a complex p stands for the pair p, conj p: the real double
  /// step of Benner, Kuerschner and Saak 2013, Alg. 3): updates the residual factor W, appends
  /// the new columns to Z and records the shifts and iteration count in `result`.
  void step(Complex p, bool tr, Matrix& W, GrowingFactor& Z, AdiResult& result) {
    const Index it = result.iterations + 1;
    if (!(p.real() < 0.0))
      throw NumericalError("low-rank ADI: shift p = " + number_text(p) + " at iteration " +
                           std::to_string(it) + " is not in the open left half-plane");
    auto breakdown = [&](const std::string& what) {
      return NumericalError("low-rank ADI: breakdown at iteration " + std::to_string(it) + ": " +
                            what);
    };
    const std::string solve_failed =
        "the solve with the shift p = " + number_text(p) + " returned a non-finite value";
    const auto fact = factorization(p, it);
    if (p.imag() == 0.0) {
      // (A + p E) V = W:  V = -(s E - A)^-1 W at s = -p.
      const Matrix V = -ops.solve(*fact, -p.real(), W, tr);
      if (!V.allFinite()) throw breakdown(solve_failed);
      W -= (2.0 * p.real()) * ops.apply_e(V, tr);
      Z.append(std::sqrt(-2.0 * p.real()) * V);
      result.iterations += 1;
      result.shifts.push_back(p);
    } else {
      const ComplexMatrix V = -ops.solve(*fact, -p, W, tr);
      if (!V.allFinite()) throw breakdown(solve_failed);
      const double gamma = 2.0 * std::sqrt(-p.real());
      const double delta = p.real() / p.imag();
      const Matrix Vr = V.real(), Vi = V.imag();
      const Matrix Vc = Vr + delta * Vi;
      W += (gamma * gamma) * ops.apply_e(Vc, tr);
      Matrix block(Vc.rows(), 2 * V.cols());
      block.leftCols(V.cols()) = gamma * Vc;
      block.rightCols(V.cols()) = (gamma * std::sqrt(delta * delta + 1.0)) * Vi;
      Z.append(block);
      result.iterations += 2;
      result.shifts.push_back(p);
      result.shifts.push_back(std::conj(p));
    }
    if (!W.allFinite())
      throw breakdown("the residual factor is not finite after the shift p = " + number_text(p));
  }

  /// The ADI iteration from W_0 = W with the residual W_k S W_k' (S == nullptr: S = I, the plain
  /// equation); rhs_norm = ||W_0 S W_0'||_2 > 0. Returns the uncompressed factor (X_k = L S~ L',
  /// S~ = diag(S, ..., S)) and fills the iteration fields of `result` (residuals, steps, shifts,
  /// shift_sets, iterations, residual, converged, message).
  Matrix iterate(GramianSide side, Matrix W, const Matrix* S, double rhs_norm, AdiResult& result) {
    const bool tr = side == GramianSide::Observability;
    GrowingFactor Z(ops.state_size(), std::max<Index>(4 * W.cols(), 16));
    ShiftQueue queue(*this, tr, W, result);
    if (!queue.refill(Z)) {
      throw NumericalError(
          "low-rank ADI (" + to_string(side) +
          "): no admissible shift: every "
          "Ritz value of the initial " +
          to_string(options.shifts) + " shift set is infinite, zero or on the imaginary axis (" +
          std::to_string(result.mirrored_ritz_values) + " had Re >= 0); an undamped model?");
    }
    double res = 1.0;
    while (result.iterations < options.max_iterations && res > options.tolerance) {
      check_interrupt(fmt::format("low-rank ADI, iteration {}", result.iterations + 1));
      const Complex p = queue.next(Z);
      step(p, tr, W, Z, result);
      res = (S != nullptr ? ldl_norm(W, *S) : gram_norm(W)) / rhs_norm;
      result.residuals.push_back(res);
      result.steps.push_back({p, res, Z.cols()});
    }
    result.residual = res;
    result.converged = res <= options.tolerance;
    result.message =
        std::string(result.converged ? "converged" : "not converged") + ": residual " +
        number_text(res) + (result.converged ? " <= " : " > ") + number_text(options.tolerance) +
        " after " + std::to_string(result.iterations) + " iterations (rank " +
        std::to_string(Z.cols()) + (result.converged ? ")" : ", max_iterations reached)");
    if (result.mirrored_ritz_values > 0)
      result.message += "; " + std::to_string(result.mirrored_ritz_values) +
                        " Ritz values with Re >= 0 were mirrored";
    return Z.take();
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
  AdiRealOps ops(view);
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
  const Vector ev = Eigen::SelfAdjointEigenSolver<Matrix>(Ts, Eigen::EigenvaluesOnly).eigenvalues();
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
  out.controllability =
      adi.solve(GramianSide::Controllability, balanced_pair(E_Lb, view.input_matrix()),
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
