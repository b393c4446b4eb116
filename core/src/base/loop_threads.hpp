#pragma once
// loop_threads.hpp: the thread count of one parallel loop on a loaded machine, chosen by what the
// loop has measured. Private to core (parallel_for.hpp, band_error.cpp).
#include <array>
#include <mutex>

#include "ecmor/base/threads.hpp"
#include "ecmor/base/types.hpp"

namespace ecmor::detail {

/// One per loop (call site). While no other process keeps cores busy, a loop runs with the
/// budget's limit. Under load two counts compete: the cores the load leaves (parallel_threads(),
/// often 1) and the limit. Which is faster depends on the loop's grain, so the loop measures both:
/// its wall time per iteration with each, smoothed; it runs the faster one and tries the other
/// every 8th time. Why: one thread gets a third of the machine's time beside two busy processes
/// on two cores, two threads get half of it; but two threads that meet at a join wait for the one
/// the scheduler has just taken off its core. Coarse loops (a factorisation per iteration) gain
/// from the second thread, fine ones (a small dense solve per iteration) lose
/// (docs/benchmarks.md, "Under load (issue 50)"). A trial of the limit costs about a scheduler
/// time slice at the join when the load has taken a thread off its core, so a loop whose runs
/// with the load's count take less than kTrialSeconds is not tried with more: it cannot gain what
/// the trial costs (a 0.1 s run makes dozens of such loops).
class LoopThreads {
 public:
  /// The shortest run (seconds, smoothed, with the load's count) for which the limit is tried.
  static constexpr double kTrialSeconds = 0.02;

  /// The thread count for this loop's next run.
  int choose() { return choose(parallel_threads(), thread_budget().limit); }

  /// The same for a load's count `low` and a limit `high` given (tests).
  int choose(int low, int high) {
    if (low >= high) return high;
    std::lock_guard<std::mutex> lock(m_mutex);
    m_low = low;
    m_high = high;
    ++m_choices;
    int pick = 0;
    if (m_runs[0] < 2) {
      pick = 0;
    } else if (m_per_run[0] < kTrialSeconds && m_runs[1] == 0) {
      pick = 0;
    } else if (m_runs[1] < 2) {
      pick = 1;
    } else {
      const int best = m_per_item[1] < m_per_item[0] ? 1 : 0;
      pick = m_choices % 8 == 0 ? 1 - best : best;
    }
    return pick == 1 ? high : low;
  }

  /// Records a run of `items` iterations with `threads` (as choose() gave it) in `seconds`.
  void record(int threads, Index items, double seconds) {
    if (items <= 0) return;
    std::lock_guard<std::mutex> lock(m_mutex);
    if (m_low >= m_high || (threads != m_low && threads != m_high)) return;
    const int k = threads == m_high ? 1 : 0;
    const double per_item = seconds / static_cast<double>(items);
    m_per_item[k] = m_runs[k] == 0 ? per_item : 0.7 * m_per_item[k] + 0.3 * per_item;
    m_per_run[k] = m_runs[k] == 0 ? seconds : 0.7 * m_per_run[k] + 0.3 * seconds;
    ++m_runs[k];
  }

 private:
  std::mutex m_mutex;
  std::array<double, 2> m_per_item{};  // smoothed seconds per iteration: [0] low, [1] high
  std::array<double, 2> m_per_run{};   // smoothed seconds per run
  std::array<long, 2> m_runs{};
  long m_choices = 0;
  int m_low = 1, m_high = 1;
};

}  // namespace ecmor::detail
