#pragma once
/// \file recent_factorizations.hpp
/// A ShiftedSolver that keeps its most recent factorisations for the next caller who asks for the
/// same combination. The run's error control and its reducer share one solver: a full solve made
/// for the error where it peaks is very often followed by the reducer asking for P(s) at that
/// same frequency (a greedy strategy puts its next expansion point there), and the kept
/// factorisation then serves it at no cost. Weights are compared exactly: a combination that
/// differs in the last bit is factorised anew, never approximated.
///
/// What it costs: the memory of `keep` factorisations beyond the lifetime their callers give
/// them. Thread-safe, like every ShiftedSolver.

#include <cstdint>
#include <list>
#include <memory>
#include <mutex>

#include "ecmor/export.hpp"
#include "ecmor/linalg/shifted_solver.hpp"

namespace ecmor {

class ECMOR_API RecentFactorizations final : public ShiftedSolver {
 public:
  /// Wraps `inner` (not owned; it must outlive this object) and keeps up to `keep` >= 0
  /// factorisations.
  RecentFactorizations(ShiftedSolver& inner, Index keep);

  Index size() const override { return m_inner.size(); }
  Index terms() const override { return m_inner.terms(); }
  std::string backend() const override { return m_inner.backend(); }
  std::shared_ptr<const Factorization> factorize_combination(
      std::span<const Complex> weights) override;
  ComplexMatrix apply_combination(std::span<const Complex> weights,
                                  const ComplexMatrix& x) const override {
    return m_inner.apply_combination(weights, x);
  }
  ComplexMatrix apply_combination_transposed(std::span<const Complex> weights,
                                             const ComplexMatrix& x) const override {
    return m_inner.apply_combination_transposed(weights, x);
  }
  /// The inner solver's counters: factorisations actually made.
  SolverCounters counters() const override { return m_inner.counters(); }
  bool concurrent() const override { return m_inner.concurrent(); }
  Index reuse_limit() const override { return m_inner.reuse_limit(); }
  /// The inner solver's plan with this object's `keep` as the kept factorisations; a plan that
  /// keeps none (MemoryPlan::kept 0) sets `keep` to 0.
  MemoryPlan plan_memory(Index kept) override;

  /// Requests served by a kept factorisation so far.
  std::int64_t reuses() const;

 private:
  struct Kept {
    std::vector<Complex> weights;
    std::shared_ptr<const Factorization> factorization;
  };
  ShiftedSolver& m_inner;
  Index m_keep;
  mutable std::mutex m_mutex;
  std::list<Kept> m_kept;  // most recent first
  std::int64_t m_reuses = 0;
};

}  // namespace ecmor
