#include "point_search.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>

#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"
#include "prune_points.hpp"

namespace ecmor::point_search {

using strategy_support::Candidate;
using strategy_support::sci;
using strategy_support::Stagnation;

namespace {

// The run's result when it ends; none while it goes on.
using End = std::optional<StrategyResult>;

// One run of the outer loop (point_search.hpp): its state between the phases start, optimum and
// grow, and the ways it ends.
class PointSearch {
 public:
  PointSearch(strategy_support::StrategyRun& run, const PointSearchOptions& o,
              const std::string& strategy, const Optimiser& optimise)
      : m_run(run),
        m_ctx(run.context()),
        m_o(o),
        m_strategy(strategy),
        m_optimise(optimise),
        m_objective(run, o.moments, o.error_floor, o.stable_only),
        // Peaks taken from each assessed model: as many as the estimator refines, at least 5.
        m_peak_count(o.peaks_per_assessment > 0
                         ? o.peaks_per_assessment
                         : std::max<Index>(5, m_ctx.estimator->options().refine_peaks)),
        m_max_order(std::min(o.max_order, m_ctx.reducer->max_order())),
        m_reducer_limit(m_ctx.reducer->max_order() <= o.max_order),
        // Points closer than this in log10 f count as one when growing (as greedy's
        // min_separation default: 1e-3 of the band's log width).
        m_separation(1e-3 * (m_objective.upper() - m_objective.lower())),
        m_stagnation(o.stagnation_window, o.stagnation_ratio) {
    m_x = o.linear_spacing
              ? linear_spaced(m_objective.lower(), m_objective.upper(), o.initial_points)
              : log_spaced(m_objective.lower(), m_objective.upper(), o.initial_points);
  }

  StrategyResult run() {
    // The start may itself be unusable (a point on an eigenvalue): then the optimiser
    // starts from it all the same and steers away (its evaluation counts as a failure).
    if (End end = assess_set("start", "the start", " (start points)", "at the start")) {
      return std::move(*end);
    }
    Index reoptimized = 0;  // re-optimisations at the current p
    while (true) {
      bool missed_peak = false;
      if (End end = optimise_and_assess(missed_peak)) return std::move(*end);
      // The full, refined evaluation found much more error than the sample set showed: the
      // optimiser was steered by samples that miss a peak. The peaks are samples now; optimise
      // the same points again before paying for another point.
      if (missed_peak && reoptimized < m_o.reoptimize) {
        ++reoptimized;
        continue;
      }
      if (End end = grow()) return std::move(*end);
      reoptimized = 0;
      // Assess the grown set: it may already pass, saving an optimisation at the same order.
      if (End end = assess_set("grow", "the grown set", " (grown set, before optimising)",
                               "after growing to " + std::to_string(m_x.size()) + " points")) {
        return std::move(*end);
      }
    }
  }

 private:
  std::string points_text() const { return std::to_string(m_x.size()) + " points"; }

  // Reduces and assesses the set m_x without optimising it (phase "start" or "grow"); a set the
  // reducer cannot reduce is left to the optimiser, which steers away from it.
  End assess_set(const std::string& phase, const std::string& what, const std::string& where,
                 const std::string& stop_where) {
    std::optional<ReducerResult> reduced;
    try {
      reduced = m_objective.reduce(m_x);
    } catch (const Interrupted&) {
      throw;  // the run's stop request, not a property of x
    } catch (const Error&) {
      return std::nullopt;
    }
    if (reduced->V.cols() > m_max_order) {
      return over_order(reduced->V.cols(), what + " with " + points_text());
    }
    m_c = m_run.assess(std::move(*reduced), phase,
                       {{"points", static_cast<double>(m_x.size())},
                        {"samples", static_cast<double>(m_objective.samples().size())}});
    ++m_assessments;
    // The first assessed model starts the stagnation trace (a first record never stagnates).
    if (m_assessments == 1) m_stagnation.record(m_run.best_error());
    m_objective.add_peaks(m_c.error, m_peak_count, m_o.max_added_samples);
    if (m_c.passed) return converged(where);
    if (m_run.stopped()) {
      return m_run.finish(Termination::Interrupted, "stopped by request " + stop_where);
    }
    return std::nullopt;
  }

  // One optimisation at the current p and the assessment of its optimum (phase "optimum").
  // `missed_peak`: the assessment found more than twice the error of the sample set.
  End optimise_and_assess(bool& missed_peak) {
    if (m_assessments >= m_o.max_iterations) {
      return m_run.finish(
          Termination::IterationLimit,
          "iteration budget max_iterations = " + std::to_string(m_o.max_iterations) +
              " (assessed models) used up with " + points_text() + ": " + m_run.shortfall());
    }
    m_objective.begin_round();
    const Optimisation opt = m_optimise(m_objective, m_x);
    if (m_run.stopped()) {
      return m_run.finish(Termination::Interrupted,
                          "stopped by request while optimising " + points_text());
    }
    if (m_objective.best_x().empty()) {
      return m_run.finish(Termination::Failed, m_strategy + ": every one of " +
                                                   std::to_string(m_objective.round_evaluations()) +
                                                   " objective evaluations with " + points_text() +
                                                   " failed; last: " + m_objective.last_failure());
    }
    m_x = m_objective.best_x();
    ReducerResult reduced = m_objective.reduce(m_x);
    if (reduced.V.cols() > m_max_order) {
      return over_order(reduced.V.cols(), "the optimum with " + points_text());
    }
    // The optimiser's own report (algorithm, stop reason) goes into the history note.
    if (!opt.status.empty()) reduced.note += (reduced.note.empty() ? "" : "; ") + opt.status;
    m_c = m_run.assess(std::move(reduced), "optimum", diagnostics(opt));
    ++m_assessments;
    const double sample_sup = std::pow(10.0, m_objective.best_value()) - m_objective.floor();
    m_objective.add_peaks(m_c.error, m_peak_count, m_o.max_added_samples);
    if (m_c.passed) return converged("");
    if (m_run.stopped()) {
      return m_run.finish(Termination::Interrupted,
                          "stopped by request after optimising " + points_text());
    }
    if (m_run.stagnated(m_stagnation)) {
      return m_run.finish(Termination::Stagnated, "band error stagnated at " +
                                                      sci(m_stagnation.last()) + " over the last " +
                                                      std::to_string(m_stagnation.window()) +
                                                      " assessed models (" + points_text() +
                                                      "); tolerance " + sci(m_ctx.tolerance));
    }
    missed_peak = m_c.error.sup_relative > 2.0 * sample_sup;
    return std::nullopt;
  }

  // The optimisation's diagnostics for the history record of its optimum.
  std::map<std::string, double> diagnostics(const Optimisation& opt) const {
    std::map<std::string, double> diag = opt.diagnostics;
    diag["points"] = static_cast<double>(m_x.size());
    diag["evaluations"] = static_cast<double>(m_objective.round_evaluations());
    diag["failed_evaluations"] = static_cast<double>(m_objective.round_failures());
    diag["objective_start"] = m_objective.start_value();
    diag["objective_optimum"] = m_objective.best_value();
    diag["samples"] = static_cast<double>(m_objective.samples().size());
    return diag;
  }

  // Grow: new points where the optimum's error peaks (its supremum first, then other local
  // maxima above the tolerance, up to points_per_growth); the others stay (warm start).
  End grow() {
    const Index p = static_cast<Index>(m_x.size());
    if (p + 1 > m_o.max_points) {
      return m_run.finish(Termination::MaxOrderReached,
                          "point budget max_points = " + std::to_string(m_o.max_points) +
                              " reached (order " + std::to_string(m_c.order()) +
                              "): " + m_run.shortfall());
    }
    const std::vector<double> added =
        growth_points(m_c.error, m_x, std::min(m_o.points_per_growth, m_o.max_points - p),
                      m_ctx.tolerance, m_separation, m_ctx.estimator->band());
    const Index k = static_cast<Index>(added.size());
    // Each point adds about the same number of columns (2 m per moment for a complex point).
    const Index next_order = m_c.order() + k * ((m_c.order() + p - 1) / p);
    if (next_order > m_max_order) {
      return m_run.finish(order_termination(), order_limit_text() + " would be exceeded by " +
                                                   std::to_string(p + k) + " points (about order " +
                                                   std::to_string(next_order) +
                                                   "): " + m_run.shortfall());
    }
    m_x.insert(m_x.end(), added.begin(), added.end());
    std::sort(m_x.begin(), m_x.end());
    return std::nullopt;
  }

  // The order budget holds for every assessed model, not only for the predicted growth: the
  // reducer may deliver more columns than p points imply at the start or at an optimum (fewer
  // deflated directions). Such a model is not assessed; the cost is its one reduction.
  StrategyResult over_order(Index delivered, const std::string& what) {
    return m_run.finish(
        order_termination(),
        order_limit_text() + " exceeded: " + what + " gave order " + std::to_string(delivered) +
            " (not assessed): " +
            (m_run.most_accurate() ? m_run.shortfall() : std::string("no model assessed")));
  }
  Termination order_termination() const {
    return m_reducer_limit ? Termination::ReducerExhausted : Termination::MaxOrderReached;
  }
  std::string order_limit_text() const {
    return (m_reducer_limit ? "the reducer delivers at most order " : "order budget max_order = ") +
           std::to_string(m_max_order);
  }

  StrategyResult converged(const std::string& where) {
    // The first passing set usually holds more than the tolerance needs (every point has the
    // same moments, growth adds points where the error peaked): drop what it does not need.
    std::string pruned;
    if (m_o.prune) {
      const Candidate first = *m_run.smallest_pass();
      pruned = strategy_support::prune_points(
          m_run, first.result.points.empty() ? m_objective.points_of(m_x) : first.result.points,
          first, std::numeric_limits<Index>::max(), [this](const std::vector<ExpansionPoint>& pts) {
            return strategy_support::reduce_at(*m_ctx.reducer, pts);
          });
    }
    const Candidate& c = *m_run.smallest_pass();
    return m_run.finish(Termination::Converged,
                        "band error " + sci(c.error.sup_relative) + " <= tolerance " +
                            sci(m_ctx.tolerance) + " at order " + std::to_string(c.order()) +
                            " with " + std::to_string(c.result.points.size()) + " points" + where +
                            m_run.verified_phrase() + pruned);
  }

  strategy_support::StrategyRun& m_run;
  StrategyContext& m_ctx;
  const PointSearchOptions& m_o;
  const std::string& m_strategy;
  const Optimiser& m_optimise;
  PointObjective m_objective;
  const Index m_peak_count;
  const Index m_max_order;
  const bool m_reducer_limit;  // the reducer's own maximum is the lower cap
  const double m_separation;
  Stagnation m_stagnation;
  std::vector<double> m_x;  // log10 of the points' frequencies
  Candidate m_c;            // the last assessed model
  Index m_assessments = 0;
};

}  // namespace

StrategyResult run_point_search(StrategyContext& ctx, const PointSearchOptions& o,
                                const std::string& strategy, const Optimiser& optimise) {
  strategy_support::StrategyRun run(ctx);
  return strategy_support::guarded(
      run, [&]() -> StrategyResult { return PointSearch(run, o, strategy, optimise).run(); });
}

}  // namespace ecmor::point_search
