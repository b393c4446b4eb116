#pragma once
// second_order_view.hpp: the solver of the recovered second-order model of a first-order model
// with second-order structure (ecmor::second_order_form), answered by the driver's first-order
// solver. Private to the krylov plugin (see README.md, "Second-order structure of first-order
// models").
//
// The first-order model is E x' = A x + B u with x = [q; v], E = blkdiag(F, M),
// A = [0 F; -K -D], B = [0; B2] (F = E11 symmetric positive definite). At a shift s,
//
//     (s E - A) [x1; x2] = [0; b]   gives  x2 = s x1,  (s^2 M + s D + K) x1 = b,
//     (s E - A)^T [y1; y2] = [c; 0] gives  F' y1 = (s M' + D') y2,  (s^2 M + s D + K)^T y2 = c,
//
// so one factorisation of s E - A (by the shared solver: its symbolic analysis, its counters, its
// backend) gives the second-order solves P(s)^-1 b = top half and P(s)^-T c = bottom half. The
// Krylov engines only ask for the combinations P(s0) = K + s0 D + s0^2 M (weights s0^k) and for
// products with K, D, M, which are the recovered sparse matrices themselves.
#include <fmt/format.h>

#include <cmath>
#include <memory>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor::krylov {

/// P(s)^-1 and P(s)^-T of the second-order model through a factorisation of s E - A.
class FirstOrderBackedFactorization final : public Factorization {
 public:
  /// \param first_order factorisation of s E - A (2n x 2n); \param scale c with the requested
  /// combination = c P(s); \param weights the weights that were requested.
  FirstOrderBackedFactorization(std::shared_ptr<const Factorization> first_order, Complex scale,
                                std::vector<Complex> weights)
      : m_first(std::move(first_order)),
        m_n(m_first->size() / 2),
        m_scale(scale),
        m_weights(std::move(weights)) {}

  Index size() const override { return m_n; }
  bool is_complex() const override { return m_first->is_complex(); }
  std::string method() const override { return m_first->method() + " (first-order pencil)"; }
  const std::vector<Complex>& weights() const override { return m_weights; }
  double rcond() const override { return m_first->rcond(); }

  Matrix solve(const Matrix& B) const override { return second_order_solve(B, false); }
  ComplexMatrix solve(const ComplexMatrix& B) const override {
    return second_order_solve(B, false);
  }
  Matrix solve_transposed(const Matrix& B) const override { return second_order_solve(B, true); }
  ComplexMatrix solve_transposed(const ComplexMatrix& B) const override {
    return second_order_solve(B, true);
  }

 private:
  /// P(s)^-1 B = top half of (s E - A)^-1 [0; B], P(s)^-T B = bottom half of (s E - A)^-T [B; 0]
  /// (see the file comment), divided by the combination's scale.
  template <class Dense>
  Dense second_order_solve(const Dense& B, bool transposed) const {
    if constexpr (std::is_same_v<Dense, Matrix>) {
      if (m_scale.imag() != 0.0) {
        throw NumericalError("krylov: a real solve was asked of a complex combination");
      }
    }
    Dense rhs = Dense::Zero(2 * m_n, B.cols());
    rhs.middleRows(transposed ? 0 : m_n, m_n) = B;
    const Dense x = transposed ? m_first->solve_transposed(rhs) : m_first->solve(rhs);
    if constexpr (std::is_same_v<Dense, Matrix>) {
      return x.middleRows(transposed ? m_n : 0, m_n) / m_scale.real();
    } else {
      return x.middleRows(transposed ? m_n : 0, m_n) / m_scale;
    }
  }

  std::shared_ptr<const Factorization> m_first;
  Index m_n;
  Complex m_scale;
  std::vector<Complex> m_weights;
};

/// A ShiftedSolver of the recovered second-order model (T_0 = K, T_1 = D, T_2 = M) whose
/// factorisations are those of the first-order solver (T_0 = -A, T_1 = E) at the same shift.
class SecondOrderView final : public ShiftedSolver {
 public:
  /// Both must outlive the view; `model` is the second_order_form() of the first-order model the
  /// solver is bound to.
  SecondOrderView(ShiftedSolver& first_order, const SecondOrderModel& model)
      : m_first(first_order), m_model(model) {}

  Index size() const override { return m_model.size(); }
  Index terms() const override { return 3; }
  std::string backend() const override { return m_first.backend() + " (first-order pencil)"; }

  /// Only combinations c (K + s D + s^2 M), i.e. weights (c, c s, c s^2) with c != 0, are
  /// factorisable this way (the only ones the Krylov engines ask for: c = 1).
  /// \throws InputError for any other weights.
  std::shared_ptr<const Factorization> factorize_combination(
      std::span<const Complex> weights) override {
    if (weights.size() != 3 || weights[0] == Complex(0.0)) {
      throw InputError(
          "krylov: the second-order view of a first-order model factorises "
          "K + s D + s^2 M only");
    }
    const Complex c = weights[0];
    const Complex s = weights[1] / c;
    // Weights s0^k come from repeated multiplication; allow for the rounding of that product.
    const Complex w2 = c * s * s;
    if (std::abs(weights[2] - w2) > 1e-13 * std::max(std::abs(weights[2]), std::abs(w2))) {
      throw InputError(fmt::format(
          "krylov: the second-order view of a first-order model factorises K + s D + s^2 M only; "
          "weights ({}, {}, {}) are not of that form",
          weights[0].real(), weights[1].real(), weights[2].real()));
    }
    // c (s E - A) = c T_0 + c s T_1: the first-order pencil at s, scaled like the request.
    const std::vector<Complex> w1 = {c, c * s};
    auto first = m_first.factorize_combination(w1);
    return std::make_shared<FirstOrderBackedFactorization>(
        std::move(first), c, std::vector<Complex>(weights.begin(), weights.end()));
  }

  ComplexMatrix apply_combination(std::span<const Complex> weights,
                                  const ComplexMatrix& x) const override {
    return combine(weights, x, false);
  }
  ComplexMatrix apply_combination_transposed(std::span<const Complex> weights,
                                             const ComplexMatrix& x) const override {
    return combine(weights, x, true);
  }

  SolverCounters counters() const override { return m_first.counters(); }

 private:
  ComplexMatrix combine(std::span<const Complex> weights, const ComplexMatrix& x,
                        bool transposed) const {
    if (weights.size() != 3) {
      throw InputError(fmt::format("krylov: {} weights for the 3 terms K, D, M", weights.size()));
    }
    ComplexMatrix y = ComplexMatrix::Zero(m_model.size(), x.cols());
    const SparseMatrix* T[3] = {&m_model.K, &m_model.D, &m_model.M};
    for (std::size_t k = 0; k < 3; ++k) {
      if (weights[k] == Complex(0.0)) continue;
      // Real sparse products with the real and imaginary parts: no complex copy of T.
      const Matrix re = x.real(), im = x.imag();
      Matrix Tre, Tim;
      if (transposed) {
        Tre = T[k]->transpose() * re;
        Tim = T[k]->transpose() * im;
      } else {
        Tre = *T[k] * re;
        Tim = *T[k] * im;
      }
      y += weights[k] * (Tre.cast<Complex>() + Complex(0.0, 1.0) * Tim.cast<Complex>());
    }
    return y;
  }

  ShiftedSolver& m_first;
  const SecondOrderModel& m_model;
};

}  // namespace ecmor::krylov
