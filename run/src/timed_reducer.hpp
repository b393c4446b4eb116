#pragma once
// timed_reducer.hpp: the reduction proper, measured apart from the error control around it.
#include <chrono>
#include <cstdint>

#include "ecmor/linalg/recent_factorizations.hpp"
#include "ecmor/plugin/reducer.hpp"

namespace ecmor::run {

/// Wraps the configured reducer to measure the reduction proper: wall time and solver work inside
/// setup() and reduce(), apart from the error estimation around them. setup() counts: the low-rank
/// ADI of balanced truncation factorises there (rail_5177_bt: 123 Cholesky factorisations that the
/// summary once left out of the reducer's count).
class TimedReducer final : public Reducer {
 public:
  TimedReducer(Reducer& inner, const RecentFactorizations& solver)
      : m_inner(inner), m_solver(solver) {}
  void setup(const ReductionContext& context) override {
    const Account account{*this};
    m_inner.setup(context);
  }
  ReducerResult reduce(const ReductionRequest& request) override {
    const Account account{*this};
    ++m_calls;
    return m_inner.reduce(request);
  }
  Index max_order() const override { return m_inner.max_order(); }
  Index order_step() const override { return m_inner.order_step(); }

  double seconds() const { return m_seconds; }
  Index calls() const { return m_calls; }
  const SolverCounters& counters() const { return m_counters; }
  /// Factorisations the reducer asked for and got from the error control's full solves.
  std::int64_t reuses() const { return m_reuses; }

 private:
  // Counts the time and solver work of one call, also when it throws: the work was done.
  struct Account {
    explicit Account(TimedReducer& reducer)
        : self(reducer),
          start(std::chrono::steady_clock::now()),
          before(reducer.m_solver.counters()),
          reuses_before(reducer.m_solver.reuses()) {}
    ~Account() {
      self.m_seconds +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      self.m_counters += self.m_solver.counters() - before;
      self.m_reuses += self.m_solver.reuses() - reuses_before;
    }
    Account(const Account&) = delete;
    Account& operator=(const Account&) = delete;
    TimedReducer& self;
    std::chrono::steady_clock::time_point start;
    SolverCounters before;
    std::int64_t reuses_before;
  };

  Reducer& m_inner;
  const RecentFactorizations& m_solver;
  double m_seconds = 0.0;
  Index m_calls = 0;
  SolverCounters m_counters;
  std::int64_t m_reuses = 0;
};

}  // namespace ecmor::run
