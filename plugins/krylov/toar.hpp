#pragma once
// toar.hpp: the per-point subspace generator of the krylov plugin: a two-level orthogonal Arnoldi
// (TOAR-type) process for the moments of x(s) = P(s)^-1 B about one expansion point s0, working
// through the ShiftedSolver interface only. Private to the plugin (see README.md for the maths).
//
// With P(s0 + sigma) = P0 + sigma P1 + sigma^2 P2, the moments r_j of x about s0 satisfy
//     r_0 = P0^-1 B,   r_j = -P0^-1 (P1 r_{j-1} + P2 r_{j-2}),
// i.e. [r_j; r_{j-1}] = L [r_{j-1}; r_{j-2}] with L = [[-P0^-1 P1, -P0^-1 P2], [I, 0]]. Arnoldi on
// L would need 2N vectors; TOAR keeps every Arnoldi vector as [Q a; Q b] with one orthonormal
// N x eta matrix Q and short coefficient vectors a, b, so that the work in N is one solve, two
// sparse products and an orthogonalisation against Q per step, and span Q = span{r_0 .. r_j}
// (Lu, Su & Bai, SIAM J. Matrix Anal. Appl. 37, 2016; Bai & Su, SIAM J. Matrix Anal. Appl. 26,
// 2005). Descriptor models have P2 = 0 and the lower level is never used: plain Arnoldi on
// P0^-1 E.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <memory>
#include <type_traits>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/linalg/shifted_solver.hpp"

namespace ecmor::krylov {

/// s^k by repeated multiplication (std::pow(0 + 0i, 0.0) is NaN in libstdc++, and s0 = 0 is a
/// common point).
inline Complex ipow(Complex s, Index k) {
  Complex r(1.0, 0.0);
  for (Index i = 0; i < k; ++i) r *= s;
  return r;
}

/// Which pencil the process runs on: P(s) (right, input side) or P(s)^T (left, output side).
enum class Side { Right, Left };

/// Work and deflation counters of one engine.
struct EngineStats {
  Index solves = 0;           ///< right-hand-side columns solved with the point's factorisation
  Index arnoldi_vectors = 0;  ///< accepted (non-deflated) Arnoldi vectors
  Index candidate_deflations = 0;  ///< Arnoldi candidates dropped as dependent (band Arnoldi)
  Index q_deflations = 0;          ///< new upper parts already in span Q (no new column of Q)
};

/// What the reducer sees of an engine, whatever its arithmetic (real or complex).
class Engine {
 public:
  virtual ~Engine() = default;
  /// Runs Arnoldi steps until Q holds the moment blocks 0 .. blocks-1 (or the space is exhausted).
  virtual void extend(Index blocks) = 0;
  /// Number of blocks of Q known to be complete; kUnlimitedOrder once the Krylov space is
  /// exhausted (invariant: every further block is empty).
  virtual Index complete_blocks() const = 0;
  /// Number of columns of Q belonging to blocks 0 .. blocks-1 (a prefix: blocks are in order).
  virtual Index columns_through(Index blocks) const = 0;
  /// Real columns spanning Re and Im of the columns [from, to) of Q (the columns themselves for
  /// real arithmetic). Each complex column is turned by a phase so that its real and imaginary
  /// parts are orthogonal; a part below tol times the column's norm is rounding noise and
  /// dropped (orthonormalize_append would judge it relative to its own, tiny, norm).
  virtual Matrix real_columns(Index from, Index to) const = 0;
  /// ||Q^H Q - I||_max.
  virtual double orthogonality_loss() const = 0;
  /// ||U^H U - I||_max of the Arnoldi coefficient vectors (the second level).
  virtual double coefficient_orthogonality_loss() const = 0;
  virtual const EngineStats& stats() const = 0;
  virtual bool is_complex() const = 0;
};

template <class S>
class Toar final : public Engine {
 public:
  using Mat = Eigen::Matrix<S, Eigen::Dynamic, Eigen::Dynamic>;
  using Vec = Eigen::Matrix<S, Eigen::Dynamic, 1>;
  static constexpr bool kComplex = !std::is_same_v<S, double>;

  /// \param factorization of P(s0) (real for real s0)
  /// \param input          B (right side, N x m) or the output matrix transposed (left, N x p)
  /// \param other          the matrix that turns a solve into a transfer matrix for the
  ///                       tangential directions: C + s0 Cv (right, p x N) or B^T (left, m x N)
  /// \param directions     tangential directions l: 0 (or >= the block width) = full block
  Toar(ShiftedSolver& solver, std::shared_ptr<const Factorization> factorization, Complex s0,
       Side side, bool second_order, const Matrix& input, const ComplexMatrix& other,
       Index directions, double tolerance)
      : m_solver(solver),
        m_factorization(std::move(factorization)),
        m_side(side),
        m_second_order(second_order),
        m_tol(tolerance) {
    const Index terms = solver.terms();
    m_w1.assign(static_cast<std::size_t>(terms), Complex(0.0));
    m_w2.assign(static_cast<std::size_t>(terms), Complex(0.0));
    // P1 = sum_k k s0^(k-1) T_k, P2 = sum_k C(k,2) s0^(k-2) T_k: the Taylor coefficients of P.
    for (Index k = 1; k < terms; ++k) {
      m_w1[static_cast<std::size_t>(k)] = static_cast<double>(k) * ipow(s0, k - 1);
      if (k >= 2) {
        m_w2[static_cast<std::size_t>(k)] = static_cast<double>(k * (k - 1) / 2) * ipow(s0, k - 2);
      }
    }
    m_Q.resize(input.rows(), 0);
    const Mat X = solve(Mat(input.template cast<S>()));
    if (!X.allFinite()) {
      throw NumericalError("krylov: the start block P(s0)^-1 B has non-finite entries");
    }
    Mat start = X;
    if (directions > 0 && directions < X.cols()) {
      // Tangential directions: the l dominant right singular vectors of the transfer matrix
      // (C + s0 Cv) X (right side) or of B^T X = H(s0)^T (left side, whose right singular
      // vectors are the conjugated left ones of H).
      const Mat T = convert(other) * X;
      Eigen::JacobiSVD<Mat> svd(T, Eigen::ComputeThinV);
      start = X * svd.matrixV().leftCols(directions);
    }
    start_block(start);
  }

  void extend(Index blocks) override {
    while (!m_queue.empty() && m_queue.front().block + 1 < blocks) step();
  }

  Index complete_blocks() const override {
    return m_queue.empty() ? kUnlimitedOrder : m_queue.front().block + 1;
  }

  Index columns_through(Index blocks) const override {
    return static_cast<Index>(std::lower_bound(m_col_block.begin(), m_col_block.end(), blocks) -
                              m_col_block.begin());
  }

  Matrix real_columns(Index from, Index to) const override {
    if constexpr (!kComplex) {
      return m_Q.middleCols(from, to - from);
    } else {
      Matrix out(m_Q.rows(), 2 * (to - from));
      Index n = 0;
      for (Index j = from; j < to; ++j) {
        Matrix xy(m_Q.rows(), 2);
        xy.col(0) = m_Q.col(j).real();
        xy.col(1) = m_Q.col(j).imag();
        // [x y] R with R the eigenvectors of the 2 x 2 Gram matrix is [Re, Im] of e^{i phi} q:
        // a phase change, same complex span, orthogonal parts.
        const Eigen::Matrix2d G = xy.transpose() * xy;
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(G);
        const Matrix parts = xy * eig.eigenvectors();
        const double total = std::sqrt(std::max(G.trace(), 0.0));
        for (Index c = 1; c >= 0; --c) {  // larger part first
          if (std::sqrt(std::max(eig.eigenvalues()[c], 0.0)) > m_tol * total) {
            out.col(n++) = parts.col(c);
          }
        }
      }
      return out.leftCols(n);
    }
  }

  // Both losses are kept between calls (the reducer reports them at every request, over every
  // cached point): columns of Q and of the coefficients are only ever appended (the coefficient
  // rows are padded with zeros, which changes no inner product), so the old entries of the Gram
  // matrix never change and only the new columns of it are computed.
  double orthogonality_loss() const override {
    const Index n = m_Q.cols(), p = m_q_loss_columns;
    if (n > p) {
      Mat G = m_Q.adjoint() * m_Q.rightCols(n - p);  // [Q_old^H Q_new; Q_new^H Q_new]
      G.bottomRows(n - p) -= Mat::Identity(n - p, n - p);
      m_q_loss = std::max(m_q_loss, G.cwiseAbs().maxCoeff());
      m_q_loss_columns = n;
    }
    return m_q_loss;
  }

  double coefficient_orthogonality_loss() const override {
    const Index n = m_Ua.cols(), p = m_u_loss_columns;
    if (n > p) {
      Mat G = m_Ua.adjoint() * m_Ua.rightCols(n - p) + m_Ub.adjoint() * m_Ub.rightCols(n - p);
      G.bottomRows(n - p) -= Mat::Identity(n - p, n - p);
      m_u_loss = std::max(m_u_loss, G.cwiseAbs().maxCoeff());
      m_u_loss_columns = n;
    }
    return m_u_loss;
  }

  const EngineStats& stats() const override { return m_stats; }
  bool is_complex() const override { return kComplex; }

 private:
  struct Candidate {
    Vec a;  // upper-level coefficients (w.r.t. the Q of its creation; padded with zeros later)
    Vec b;  // lower-level coefficients
    Index block = 0;
  };

  static Mat convert(const ComplexMatrix& x) {
    if constexpr (kComplex) {
      return x;
    } else {
      return x.real();  // real point: imaginary parts are zero
    }
  }

  Mat solve(const Mat& x) {
    Mat out =
        m_side == Side::Right ? m_factorization->solve(x) : m_factorization->solve_transposed(x);
    m_stats.solves += x.cols();
    return out;
  }

  Mat apply(const std::vector<Complex>& w, const Vec& x) const {
    const ComplexMatrix xc = x.template cast<Complex>();
    return convert(m_side == Side::Right ? m_solver.apply_combination(w, xc)
                                         : m_solver.apply_combination_transposed(w, xc));
  }

  static Vec padded(const Vec& v, Index n) {
    Vec out = Vec::Zero(n);
    out.head(v.size()) = v;
    return out;
  }

  // y -> Q h + rho q_new by classical Gram-Schmidt applied twice (a third pass only when the
  // second one still removed most of the vector, i.e. severe cancellation). Appends q_new to Q
  // (tagged with `block`) unless y is numerically in span Q. Returns h (length = new eta).
  Vec orthogonalize_into_q(Vec y, Index block) {
    const double norm0 = y.norm();
    Vec h = Vec::Zero(m_Q.cols());
    double before = norm0;
    for (int pass = 0; pass < 3 && m_Q.cols() > 0; ++pass) {
      const Vec g = m_Q.adjoint() * y;
      y -= m_Q * g;
      h += g;
      const double after = y.norm();
      if (pass >= 1 && after > 0.5 * before) break;
      before = after;
    }
    const double rho = y.norm();
    if (norm0 > 0.0 && rho > m_tol * norm0) {
      m_Q.conservativeResize(Eigen::NoChange, m_Q.cols() + 1);
      m_Q.col(m_Q.cols() - 1) = y / rho;
      m_col_block.push_back(block);
      h.conservativeResize(h.size() + 1);
      h(h.size() - 1) = rho;
    } else {
      ++m_stats.q_deflations;
    }
    return h;
  }

  // Block 0: the columns of the start block into Q (with deflation of dependent columns, e.g.
  // repeated inputs), each queued as an Arnoldi candidate [Q^H r; 0].
  void start_block(const Mat& R) {
    std::vector<Vec> coefficients;
    for (Index j = 0; j < R.cols(); ++j) coefficients.push_back(orthogonalize_into_q(R.col(j), 0));
    for (Vec& a : coefficients) {
      m_queue.push_back(Candidate{padded(a, m_Q.cols()), Vec::Zero(m_Q.cols()), 0});
    }
  }

  // One band-Arnoldi step: orthonormalise the oldest candidate against the accepted Arnoldi
  // vectors (in coefficient space: Q is orthonormal, so ||[Q a; Q b]|| = ||[a; b]||); drop it if
  // it is dependent, else accept it and queue L times it as the next candidate.
  //
  // Exception safety (strong): everything that can fail (the solve, the finiteness check) runs on
  // local copies before the first change of the engine's state. The reducer keeps engines cached
  // across requests and strategies catch a failed reduce() and carry on, so a step that threw
  // halfway (candidate popped, Arnoldi vector accepted, its successor never queued) would make
  // every later request at this point silently lose Krylov directions. The only state touched
  // before the checks is the zero padding of the coefficient rows, which changes no vector.
  void step() {
    const Candidate& c = m_queue.front();
    const Index block = c.block;
    const Index eta = m_Q.cols();
    Vec a = padded(c.a, eta), b = padded(c.b, eta);
    const double norm0 = std::sqrt(a.squaredNorm() + b.squaredNorm());
    if (m_Ua.rows() < eta) {
      const Index old = m_Ua.rows();
      m_Ua.conservativeResize(eta, Eigen::NoChange);
      m_Ub.conservativeResize(eta, Eigen::NoChange);
      m_Ua.bottomRows(eta - old).setZero();
      m_Ub.bottomRows(eta - old).setZero();
    }
    for (int pass = 0; pass < 2 && m_Ua.cols() > 0; ++pass) {
      const Vec h = m_Ua.adjoint() * a + m_Ub.adjoint() * b;
      a -= m_Ua * h;
      b -= m_Ub * h;
    }
    const double norm = std::sqrt(a.squaredNorm() + b.squaredNorm());
    if (!(norm0 > 0.0) || !(norm > m_tol * norm0)) {
      m_queue.pop_front();
      ++m_stats.candidate_deflations;
      return;
    }
    a /= norm;
    b /= norm;

    // Upper part of L [Q a; Q b] = -P0^-1 (gamma P1 Q a + gamma^2 P2 Q b): one solve.
    Vec rhs = apply(m_w1, m_Q * a);
    const bool lower = m_second_order && b.squaredNorm() > 0.0;
    if (lower) rhs += apply(m_w2, m_Q * b);
    Vec y = -solve(rhs).col(0);
    // Scaling sigma = gamma tau of the linearisation, fixed at the first step (where b = 0 and
    // the weights still have gamma = 1): gamma = 1 / ||P0^-1 P1 q||, so that both levels have
    // comparable norms and the coefficient-space deflation test is not blind to the lower level.
    // The span of the moments is unchanged (r_j scales by gamma^j).
    const bool scale_now = !m_scaled && m_second_order;
    double gamma = 1.0;
    if (scale_now) {
      const double ny = y.norm();
      gamma = (ny > 0.0 && std::isfinite(ny)) ? 1.0 / ny : 1.0;
      y *= gamma;
    }
    if (!y.allFinite()) {
      throw NumericalError(fmt::format(
          "krylov: Arnoldi step {} produced non-finite values (breakdown of the recurrence)",
          m_stats.arnoldi_vectors + 1));
    }

    // Commit: nothing below can fail except by running out of memory.
    m_queue.pop_front();
    m_Ua.conservativeResize(eta, m_Ua.cols() + 1);
    m_Ub.conservativeResize(eta, m_Ub.cols() + 1);
    m_Ua.col(m_Ua.cols() - 1) = a;
    m_Ub.col(m_Ub.cols() - 1) = b;
    ++m_stats.arnoldi_vectors;
    if (scale_now) {
      for (auto& w : m_w1) w *= gamma;
      for (auto& w : m_w2) w *= gamma * gamma;
      m_scaled = true;
    }
    const Vec h = orthogonalize_into_q(y, block + 1);
    // Descriptor models: the lower level is never used, plain Arnoldi on the upper one.
    m_queue.push_back(Candidate{h, m_second_order ? a : Vec::Zero(0), block + 1});
  }

  ShiftedSolver& m_solver;
  std::shared_ptr<const Factorization> m_factorization;
  Side m_side;
  bool m_second_order;
  double m_tol;
  bool m_scaled = false;
  std::vector<Complex> m_w1, m_w2;  // weights of P1 and P2 (times gamma, gamma^2)
  Mat m_Q;                          // N x eta, orthonormal
  std::vector<Index> m_col_block;   // moment block of each column of Q (non-decreasing)
  Mat m_Ua, m_Ub;                   // eta x k coefficients of the accepted Arnoldi vectors
  std::deque<Candidate> m_queue;    // FIFO candidates (band Arnoldi)
  EngineStats m_stats;
  // Orthogonality losses of the first *_columns columns (see orthogonality_loss()).
  mutable double m_q_loss = 0.0, m_u_loss = 0.0;
  mutable Index m_q_loss_columns = 0, m_u_loss_columns = 0;
};

}  // namespace ecmor::krylov
