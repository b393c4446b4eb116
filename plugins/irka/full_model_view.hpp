#pragma once
// full_model_view.hpp: what IRKA needs of the full model, for both kinds, without assembling any
// 2N x 2N matrix. Private to the irka plugin (see README.md).
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
// interpolation vectors.
#include <fmt/format.h>

#include <variant>

#include "ecmor/error.hpp"
#include "ecmor/model.hpp"
#include "ecmor/projection.hpp"
#include "ecmor/shifted_solver.hpp"

namespace ecmor::irka {

class FullModelView {
 public:
  FullModelView(const Model& model, ShiftedSolver& solver) : m_model(model), m_solver(solver) {
    m_so = std::get_if<SecondOrderModel>(&model);
    m_ds = std::get_if<DescriptorModel>(&model);
    m_n = size_of(model);
  }

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

  /// Er = W' E V, Ar = W' A V, Br = W' B, Cr = C V of the first-order (realisation of the) model;
  /// V, W are state_size() x r.
  ReducedDescriptorModel project_first_order(const Matrix& V, const Matrix& W) const {
    if (V.rows() != state_size() || W.rows() != state_size() || V.cols() != W.cols()) {
      throw InputError(fmt::format("irka: bases of {} x {} and {} x {} for a state of size {}",
                                   V.rows(), V.cols(), W.rows(), W.cols(), state_size()));
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
  const Matrix& input() const { return m_so != nullptr ? m_so->B : m_ds->B; }

  const Model& m_model;
  ShiftedSolver& m_solver;
  const SecondOrderModel* m_so = nullptr;
  const DescriptorModel* m_ds = nullptr;
  Index m_n = 0;
};

}  // namespace ecmor::irka
