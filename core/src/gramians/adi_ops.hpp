// adi_ops.hpp: real-arithmetic products and solves with the first-order realisation (E, A) of a
// FirstOrderView, and the small dense norms by which the low-rank ADI iteration judges itself.
// Private to core (gramians); used by lowrank_adi.cpp and adi_shifts.cpp.
#pragma once

#include <array>
#include <utility>

#include "ecmor/base/types.hpp"
#include "ecmor/linalg/first_order_view.hpp"
#include "ecmor/linalg/shifted_solver.hpp"

namespace ecmor::detail {

/// Real-arithmetic operations with the first-order realisation (E, A) of the view's model; with
/// `transposed` they act with E', A' (observability side).
class AdiRealOps {
 public:
  explicit AdiRealOps(FirstOrderView& view) : m_view(view) {}

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

/// ||X' X||_2 = sigma_max(X)^2 of a tall block with few columns.
double gram_norm(const Matrix& X);

/// Eigen-decomposition of the Gram matrix X' X (largest first): the right singular vectors and
/// squared singular values of X, by one matrix product instead of a QR of the tall X.
std::pair<Vector, Matrix> gram_eigen(const Matrix& X);

/// ||W S W'||_2 for a tall W with few columns and a symmetric S: the nonzero eigenvalues of
/// W S W' are those of R S R' for the thin QR W = Q R. O(n k^2) for k columns, small next to a
/// solve with the same block.
double ldl_norm(const Matrix& W, const Matrix& S);

}  // namespace ecmor::detail
