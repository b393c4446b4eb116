#pragma once
// A small, deliberately plain interpolation reducer for strategy tests: one-sided (W = V)
// projection onto the moments of P(s)^-1 B at the requested points, for either model kind,
// through the ShiftedSolver interface. No caching, no reorthogonalised recurrence: it is meant
// for small test models, where the strategies, not the reducer, are under test. The real reducer
// is plugins/krylov.
#include <cmath>
#include <string>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/model/projection.hpp"
#include "ecmor/plugin/reducer.hpp"

namespace ecmor::test {

class InterpolationReducer final : public Reducer {
 public:
  /// default_points: used when a request has none (then moments grow round-robin to the order).
  explicit InterpolationReducer(std::vector<ExpansionPoint> default_points = {})
      : m_default(std::move(default_points)) {}

  void setup(const ReductionContext& ctx) override {
    m_model = ctx.model;
    m_solver = ctx.solver;
  }

  ReducerResult reduce(const ReductionRequest& request) override {
    ++calls;
    std::vector<ExpansionPoint> points = request.points;
    Index cap = request.order;
    if (points.empty()) {
      if (m_default.empty()) throw ConfigError("interpolation test reducer: no points");
      // Round-robin moments until the order is reached (or 50 moments per point).
      points = m_default;
      for (auto& p : points) p.moments = 0;
      Index cols = 0;
      for (Index round = 0; cols < request.order && round < 50; ++round) {
        for (auto& p : points) {
          ++p.moments;
          cols += (p.s.imag() != 0.0 ? 2 : 1) * inputs_of(*m_model);
        }
      }
    }
    Matrix V(size_of(*m_model), 0);
    for (const ExpansionPoint& p : points) {
      if (p.s.real() < 0.0) throw InputError("interpolation test reducer: Re(s0) < 0");
      append_moments(V, p);
    }
    if (cap > 0 && V.cols() > cap) V = V.leftCols(cap).eval();
    ReducerResult r;
    r.V = V;
    r.W = V;
    r.model = project(*m_model, r.V, r.W);
    r.points = points;
    r.note = std::to_string(points.size()) + " points";
    return r;
  }

  int calls = 0;

 private:
  void append_moments(Matrix& V, const ExpansionPoint& p) const {
    const Index terms = m_solver->terms();
    std::vector<Complex> w0(terms), w1(terms, 0.0), w2(terms, 0.0);
    for (Index k = 0; k < terms; ++k) {
      w0[k] = std::pow(p.s, static_cast<double>(k));
      if (k >= 1) w1[k] = static_cast<double>(k) * std::pow(p.s, static_cast<double>(k - 1));
      if (k >= 2) w2[k] = std::pow(p.s, static_cast<double>(k - 2));  // C(2,2) = 1
    }
    const auto f = m_solver->factorize_combination(w0);
    const Matrix& B = std::visit([](const auto& m) -> const Matrix& { return m.B; }, *m_model);
    ComplexMatrix prev2 = ComplexMatrix::Zero(B.rows(), B.cols());
    ComplexMatrix prev = f->solve(ComplexMatrix(B.cast<Complex>()));
    for (Index j = 0; j < p.moments; ++j) {
      if (j > 0) {
        ComplexMatrix rhs = m_solver->apply_combination(w1, prev);
        if (terms > 2) rhs += m_solver->apply_combination(w2, prev2);
        ComplexMatrix next = -f->solve(rhs);
        prev2 = prev;
        prev = next;
      }
      const double scale = prev.norm() > 0.0 ? 1.0 / prev.norm() : 1.0;
      prev *= scale;
      prev2 *= scale;
      orthonormalize_append(V, prev.real());
      if (p.s.imag() != 0.0) orthonormalize_append(V, prev.imag());
    }
  }

  std::vector<ExpansionPoint> m_default;
  const Model* m_model = nullptr;
  ShiftedSolver* m_solver = nullptr;
};

}  // namespace ecmor::test
