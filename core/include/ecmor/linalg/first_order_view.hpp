#pragma once
/// \file first_order_view.hpp
/// A first-order view of any full model, for methods defined on E x' = A x + B u (IRKA, low-rank
/// ADI, balanced truncation), without assembling any 2N x 2N matrix.
//
// A descriptor model is used as it is: E x' = A x + B u, y = C x, P(s) = s E - A.
// A second-order model M q'' + D q' + K q = B u, y = C q + Cv q' is seen through its first-order
// realisation in x = [q; q'],
//
//     E = [I 0; 0 M],  A = [0 I; -K -D],  B = [0; B],  C = [C Cv],
//
// whose solves reduce to P(s) = s^2 M + s D + K:
//
//     (s E - A) [x1; x2] = [0; B b]       <=>  P(s) x1 = B b,  x2 = s x1
//     (s E - A)^T [y1; y2] = [C' c; Cv' c] <=> P(s)^T y2 = (C + s Cv)' c,  y1 = (s M' + D') y2 -
//     Cv' c
//
// and whose projections W' E V, W' A V need only products with M, D, K. The same solves serve the
// structure-preserving variant: P(s)^-1 B b and P(s)^-T (C + s Cv)' c are the second-order
// interpolation vectors. General right-hand sides [f; g] reduce the same way:
//
//     (s E - A) [x1; x2] = [f; g]     <=>  P(s) x1 = g + (s M + D) f,   x2 = s x1 - f
//     (s E - A)^T [y1; y2] = [f; g]   <=>  P(s)^T y2 = f + s g,  y1 = (s M' + D') y2 - g

#include <string>
#include <variant>

#include "ecmor/base/error.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/model.hpp"
#include "ecmor/model/projection.hpp"

namespace ecmor {

/// The first-order realisation of a model, applied through its shifted solver. The model and the
/// solver must outlive the view.
class FirstOrderView {
 public:
  FirstOrderView(const Model& model, ShiftedSolver& solver) : m_model(model), m_solver(solver) {
    m_so = std::get_if<SecondOrderModel>(&model);
    m_ds = std::get_if<DescriptorModel>(&model);
    m_n = size_of(model);
  }
  /// A temporary (or a SecondOrderModel / DescriptorModel converted to one) would dangle.
  FirstOrderView(Model&&, ShiftedSolver&) = delete;

  bool second_order() const { return m_so != nullptr; }
  /// N (descriptor) or N of the second-order model.
  Index size() const { return m_n; }
  /// Dimension of the first-order state: N or 2N.
  Index state_size() const { return m_so != nullptr ? 2 * m_n : m_n; }
  Index inputs() const { return inputs_of(m_model); }
  Index outputs() const { return outputs_of(m_model); }
  const SecondOrderModel* so() const { return m_so; }
  ShiftedSolver& solver() { return m_solver; }

  /// The output row combination C + s Cv applied as (C + s Cv)' c (second order), C' c otherwise.
  ComplexMatrix output_transposed(Complex s, const ComplexMatrix& c) const {
    if (m_ds != nullptr) return m_ds->C.transpose().cast<Complex>() * c;
    ComplexMatrix out = m_so->C.transpose().cast<Complex>() * c;
    if (m_so->has_velocity_output()) out += s * (m_so->Cv.transpose().cast<Complex>() * c);
    return out;
  }

  /// Right first-order vectors (s E - A)^-1 B b for the columns b of `directions` (m x k).
  ComplexMatrix right(const Factorization& p, Complex s, const ComplexMatrix& directions) const {
    const ComplexMatrix rhs = input().cast<Complex>() * directions;
    const ComplexMatrix x = p.solve(rhs);
    if (m_ds != nullptr) return x;
    ComplexMatrix out(2 * m_n, x.cols());
    out.topRows(m_n) = x;
    out.bottomRows(m_n) = s * x;
    return out;
  }

  /// Left first-order vectors (s E - A)^-T C' c for the columns c of `directions` (p x k).
  ComplexMatrix left(const Factorization& p, Complex s, const ComplexMatrix& directions) const {
    const ComplexMatrix y = p.solve_transposed(output_transposed(s, directions));
    if (m_ds != nullptr) return y;
    ComplexMatrix out(2 * m_n, y.cols());
    // y1 = (s M' + D') y2 - Cv' c.
    const ComplexMatrix My = m_so->M.transpose() * y;
    const ComplexMatrix Dy = m_so->D.transpose() * y;
    out.topRows(m_n) = s * My + Dy;
    if (m_so->has_velocity_output()) {
      out.topRows(m_n) -= m_so->Cv.transpose().cast<Complex>() * directions;
    }
    out.bottomRows(m_n) = y;
    return out;
  }

  /// Second-order vectors P(s)^-1 B b (right) and P(s)^-T (C + s Cv)' c (left).
  ComplexMatrix right_second_order(const Factorization& p, const ComplexMatrix& directions) const {
    return p.solve(ComplexMatrix(input().cast<Complex>() * directions));
  }
  ComplexMatrix left_second_order(const Factorization& p, Complex s,
                                  const ComplexMatrix& directions) const {
    return p.solve_transposed(output_transposed(s, directions));
  }

  /// (s E - A)^-1 R for a first-order right-hand side R (state_size() x k); `p` factorises P(s).
  ComplexMatrix solve(const Factorization& p, Complex s, const ComplexMatrix& R) const {
    check_state_rows(R, "solve");
    if (m_ds != nullptr) return p.solve(R);
    const Index n = m_n;
    const auto f = R.topRows(n), g = R.bottomRows(n);
    const ComplexMatrix rhs = g + s * (m_so->M * f) + m_so->D * f;
    const ComplexMatrix x1 = p.solve(rhs);
    ComplexMatrix out(2 * n, R.cols());
    out.topRows(n) = x1;
    out.bottomRows(n) = s * x1 - f;
    return out;
  }

  /// (s E - A)^-T R for a first-order right-hand side R (state_size() x k).
  ComplexMatrix solve_transposed(const Factorization& p, Complex s, const ComplexMatrix& R) const {
    check_state_rows(R, "solve_transposed");
    if (m_ds != nullptr) return p.solve_transposed(R);
    const Index n = m_n;
    const auto f = R.topRows(n), g = R.bottomRows(n);
    const ComplexMatrix y2 = p.solve_transposed(ComplexMatrix(f + s * g));
    ComplexMatrix out(2 * n, R.cols());
    out.topRows(n) = s * (m_so->M.transpose() * y2) + m_so->D.transpose() * y2 - g;
    out.bottomRows(n) = y2;
    return out;
  }

  /// E X for a first-order block X (state_size() x k).
  Matrix apply_e(const Matrix& X) const {
    check_state_rows(X, "apply_e");
    if (m_ds != nullptr) return m_ds->E * X;
    Matrix out(2 * m_n, X.cols());
    out.topRows(m_n) = X.topRows(m_n);
    out.bottomRows(m_n) = m_so->M * X.bottomRows(m_n);
    return out;
  }

  /// E' X for a first-order block X (state_size() x k).
  Matrix apply_e_transposed(const Matrix& X) const {
    check_state_rows(X, "apply_e_transposed");
    if (m_ds != nullptr) return m_ds->E.transpose() * X;
    Matrix out(2 * m_n, X.cols());
    out.topRows(m_n) = X.topRows(m_n);
    out.bottomRows(m_n) = m_so->M.transpose() * X.bottomRows(m_n);
    return out;
  }

  /// The first-order input matrix B (state_size() x m) and output matrix C (p x state_size()).
  Matrix input_matrix() const {
    if (m_ds != nullptr) return m_ds->B;
    Matrix out = Matrix::Zero(2 * m_n, m_so->B.cols());
    out.bottomRows(m_n) = m_so->B;
    return out;
  }
  Matrix output_matrix() const {
    if (m_ds != nullptr) return m_ds->C;
    Matrix out = Matrix::Zero(m_so->C.rows(), 2 * m_n);
    out.leftCols(m_n) = m_so->C;
    if (m_so->has_velocity_output()) out.rightCols(m_n) = m_so->Cv;
    return out;
  }

  /// Er = W' E V, Ar = W' A V, Br = W' B, Cr = C V of the first-order (realisation of the) model;
  /// V, W are state_size() x r.
  ReducedDescriptorModel project_first_order(const Matrix& V, const Matrix& W) const {
    if (V.rows() != state_size() || W.rows() != state_size() || V.cols() != W.cols()) {
      throw InputError("first-order projection: bases of " + std::to_string(V.rows()) + " x " +
                       std::to_string(V.cols()) + " and " + std::to_string(W.rows()) + " x " +
                       std::to_string(W.cols()) + " for a state of size " +
                       std::to_string(state_size()));
    }
    if (m_ds != nullptr) return project(*m_ds, V, W);
    const Index n = m_n;
    const auto V1 = V.topRows(n), V2 = V.bottomRows(n);
    const auto W1 = W.topRows(n), W2 = W.bottomRows(n);
    ReducedDescriptorModel r;
    const Matrix MV2 = m_so->M * V2;
    const Matrix KV1DV2 = m_so->K * V1 + m_so->D * V2;
    r.E = W1.transpose() * V1 + W2.transpose() * MV2;
    r.A = W1.transpose() * V2 - W2.transpose() * KV1DV2;
    r.B = W2.transpose() * m_so->B;
    r.C = m_so->C * V1;
    if (m_so->has_velocity_output()) r.C += m_so->Cv * V2;
    return r;
  }

 private:
  template <typename Block>
  void check_state_rows(const Block& X, const char* what) const {
    if (X.rows() != state_size()) {
      throw InputError(std::string("first-order view: ") + what + " of a block with " +
                       std::to_string(X.rows()) + " rows; the state has " +
                       std::to_string(state_size()));
    }
  }
  const Matrix& input() const { return m_so != nullptr ? m_so->B : m_ds->B; }

  const Model& m_model;
  ShiftedSolver& m_solver;
  const SecondOrderModel* m_so = nullptr;
  const DescriptorModel* m_ds = nullptr;
  Index m_n = 0;
};

}  // namespace ecmor
