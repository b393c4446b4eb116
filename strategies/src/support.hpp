#pragma once
/// \file support.hpp
/// What every strategy does the same way: evaluate a reduced model's band error, re-check a pass
/// on the independent grid, record each step in the history, keep the smallest passing and the
/// most accurate candidate, and finish with a reason. Strategies differ only in which reduced
/// models they ask for.

#include <chrono>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"
#include "ecmor/base/options.hpp"
#include "ecmor/measures/stability.hpp"
#include "ecmor/strategies/strategy.hpp"

namespace ecmor::strategy_support {

/// "1.234e-04".
std::string sci(double v);

/// Is `model` as stable as the full model? reduced_model_stability against context.full_rigid;
/// `unstable` is a known count of poles with Re >= 0 (the estimator's or the reducer's), -1 when
/// unknown.
ReducedStability judge_stability(const StrategyContext& context, const ReducedModel& model,
                                 Index unstable = -1);

/// The stagnation rule of every strategy. After each step the strategy records its best band
/// error so far; the run has stagnated when that error did not fall below `ratio` times its value
/// `window` steps before. No progress (an equal value, inf after inf) stagnates, and so does a
/// NaN, which is never progress. A window of 0 never stagnates.
class Stagnation {
 public:
  Stagnation(Index window, double ratio) : m_window(window), m_ratio(ratio) {}
  /// Records `best` and returns true when the run has stagnated.
  bool record(double best) {
    m_trace.push_back(best);
    if (m_window <= 0 || static_cast<Index>(m_trace.size()) <= m_window) return false;
    return !(best < m_ratio * before());
  }
  /// The best error `window` steps before the last record (for the message).
  double before() const { return m_trace[m_trace.size() - 1 - static_cast<std::size_t>(m_window)]; }
  double last() const { return m_trace.back(); }
  Index window() const { return m_window; }
  /// Forgets the records: the errors recorded so far are not comparable with the next ones.
  void reset() { m_trace.clear(); }

 private:
  Index m_window;
  double m_ratio;
  std::vector<double> m_trace;
};

/// The options Stagnation reads, with the one rule for every strategy: stagnation_window >= 0 (0:
/// never stagnates) and stagnation_ratio in (0, 1] (a ratio of 0 would make every step
/// "stagnated": no error is below 0). `doc` says what a step is in that strategy.
template <class O>
Option<O> stagnation_window_option(Index O::*field, std::string doc) {
  return option("stagnation_window", field, std::move(doc)).range(Range::at_least(0));
}
template <class O>
Option<O> stagnation_ratio_option(double O::*field, std::string doc) {
  return option("stagnation_ratio", field, std::move(doc)).range(Range::open_closed(0, 1));
}

/// The reduced model at exactly these points, with no cap on the order (ReductionRequest's
/// semantics for explicit points). The result always lists its points: a reducer that leaves
/// them out used the requested ones, and the history must show them.
ReducerResult reduce_at(Reducer& reducer, const std::vector<ExpansionPoint>& points);

/// One assessed reduced model.
struct Candidate {
  ReducerResult result;
  BandError error;
  ReducedStability stability;
  bool stable = false;  ///< stability.accepted()
  /// Meets the tolerance on the estimator's sampling and on the independent re-check, and is
  /// stable (an unstable model is never reported as converged).
  bool passed = false;
  /// Meets the tolerance on the estimator's sampling and is stable, but was assessed without its
  /// re-check (StrategyRun::assess with verify = false); StrategyRun::confirm decides it.
  bool pending = false;
  Index order() const { return result.V.cols(); }
};

/// The bookkeeping of one strategy run: history records, best candidates, termination.
class StrategyRun {
 public:
  explicit StrategyRun(StrategyContext& context);

  StrategyContext& context() { return m_ctx; }
  Index iterations() const { return m_iteration; }
  /// True once the observer asked to stop (the strategy must then finish as Interrupted).
  bool stopped() const { return m_stop || (m_ctx.stop_requested && m_ctx.stop_requested()); }

  /// Appends one history record (and calls the observer). `extra` adds diagnostics.
  void record(const std::string& phase, const ReducerResult& result, const BandError& error,
              bool meets, bool stable, const std::map<std::string, double>& extra = {});

  /// Evaluates the band error of `result` (estimator.evaluate), records it under `phase`, and, if
  /// it meets the tolerance, re-checks it on the independent grid (recorded as "verify"). Tracks
  /// the smallest passing and the most accurate candidate.
  /// With verify = false a candidate that meets the tolerance is left `pending`, not re-checked
  /// and not tracked as passing, until confirm(): a strategy that only steps on from it (pruning)
  /// re-checks the last one instead of each.
  Candidate assess(ReducerResult result, const std::string& phase,
                   const std::map<std::string, double>& extra = {}, bool verify = true);
  /// The re-check of a pending candidate (recorded as "verify"); tracks it if it passes.
  void confirm(Candidate& c, const std::map<std::string, double>& extra = {});

  /// Records a candidate whose error was evaluated elsewhere (e.g. on an optimiser's sample set)
  /// without the pass/verify logic; it is not tracked as a best candidate.
  void record_trial(const std::string& phase, const ReducerResult& result, const BandError& error,
                    const std::map<std::string, double>& extra = {});

  const std::optional<Candidate>& smallest_pass() const { return m_smallest_pass; }
  const std::optional<Candidate>& most_accurate() const { return m_most_accurate; }
  /// Error of the most accurate candidate so far (+inf if none).
  double best_error() const;
  /// Why no candidate passed, for a termination message: "band error 3.1e-02 > tolerance 1.0e-02",
  /// or, when the most accurate model meets the tolerance but is not as stable as the full model,
  /// "band error 3.0e-05 <= tolerance 1.0e-02, but the model is unstable (<reason>)".
  std::string shortfall() const;

  /// Records the best error so far in `s` and returns true when the run has stagnated. In the
  /// estimate mode a stagnation first asks the estimator for more effort on the error
  /// (BandErrorEstimator::escalate: the dense mode under `verify: auto` when it is affordable,
  /// else more probe solves, once): the estimate may be what stalls the run. When it escalates,
  /// `s` is reset and false is returned: the caller goes on, re-assessing the model its next step
  /// starts from where that step reads its error curve (escalated() is then true once). After a
  /// switch to the dense mode the estimated errors no longer rank the candidates: the next one
  /// assessed replaces the most accurate one (a passing one, checked against the full model, is
  /// kept).
  bool stagnated(Stagnation& s);
  /// True once after stagnated() escalated (the caller re-assesses its model).
  bool escalated() { return std::exchange(m_escalated, false); }

  /// Fills and returns the result: the smallest passing candidate, else the most accurate one.
  StrategyResult finish(Termination termination, std::string message);

  /// Message tail " (verified on a 4x denser independent grid)".
  std::string verified_phrase() const;

  /// "reduction failed in iteration 4 (krylov): <what>": a breakdown named where it happened, by
  /// the iteration it ended and the reducer (not repeated when `what` already starts with it).
  std::string failure(const std::string& what, bool foreign = false) const;

  /// "stopped during iteration 4 (modal): interrupted in ARPACK dnaupd (...); band error ... >
  /// tolerance ...": where a stop request took effect inside a reducer call, and the shortfall.
  std::string interruption(const std::string& what) const;

 private:
  StrategyContext& m_ctx;
  StrategyResult m_out;
  Index m_iteration = 0;
  bool m_stop = false;
  std::chrono::steady_clock::time_point m_last;
  std::optional<Candidate> m_smallest_pass;
  std::optional<Candidate> m_most_accurate;
  double m_largest_floor = 0.0;  // the largest reference floor of the assessed candidates
  bool m_escalated = false;      // stagnated() escalated (escalated())
  bool m_rank_afresh = false;    // after a switch to the dense mode: track() replaces the best

  void track(const Candidate& c);
};

/// Runs `body` and turns exceptions into a Failed termination that keeps the best model so far.
template <class Body>
StrategyResult guarded(StrategyRun& run, Body&& body) {
  try {
    return body();
  } catch (const Interrupted& e) {
    // The time limit or a signal inside a reducer call: the best model so far is the result.
    return run.finish(Termination::Interrupted, run.interruption(e.what()));
  } catch (const Error& e) {
    return run.finish(Termination::Failed, run.failure(e.what()));
  } catch (const std::exception& e) {
    // A plugin may throw anything; the best model so far is kept and written all the same.
    return run.finish(Termination::Failed, run.failure(e.what(), /*foreign=*/true));
  }
}

/// Geometric centre of the band, sqrt(f_min f_max).
double band_centre_hz(const Band& band);

/// The frequency of an expansion point, Im(s) / 2 pi.
double hz_of(const ExpansionPoint& p);

/// One growth step of a point set toward a frequency of large error.
struct PointStep {
  std::vector<ExpansionPoint> points;  ///< the set after the step
  bool adds_point = false;             ///< a new point (else a moment more at an existing one)
  double at_hz = 0.0;                  ///< the new point, or the point given the moment
  Index moments_there = 0;             ///< that point's moments after the step
};

/// The step toward `f_hz`: one moment more at the nearest point when f lies within `separation`
/// of it in |ln f| (interpolating there again adds nothing; a higher moment fits the resonance
/// around it), else a new point at f with `moments` moments.
PointStep step_toward(const std::vector<ExpansionPoint>& points, double f_hz, double separation,
                      Index moments);

/// Throws ConfigError unless the reducer uses expansion points (for point-moving strategies).
void require_point_reducer(const StrategyContext& context, const std::string& strategy);

}  // namespace ecmor::strategy_support
