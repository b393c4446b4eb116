#include "point_search.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"
#include "prune_points.hpp"

namespace ecmor::point_search {

using strategy_support::Candidate;
using strategy_support::sci;
using strategy_support::Stagnation;

StrategyResult run_point_search(StrategyContext& ctx, const PointSearchOptions& o,
                                const std::string& strategy, const Optimiser& optimise) {
  strategy_support::StrategyRun run(ctx);
  auto finish = [&](Termination t, std::string message) {
    return run.finish(t, std::move(message));
  };
  return strategy_support::guarded(run, [&]() -> StrategyResult {
    PointObjective objective(run, o.moments, o.error_floor, o.stable_only);
    // Peaks taken from each assessed model: as many as the estimator refines, at least 5.
    const Index peak_count = o.peaks_per_assessment > 0
                                 ? o.peaks_per_assessment
                                 : std::max<Index>(5, ctx.estimator->options().refine_peaks);
    const Index reducer_max = ctx.reducer->max_order();
    const Index max_order = std::min(o.max_order, reducer_max);
    std::vector<double> x =
        o.linear_spacing ? linear_spaced(objective.lower(), objective.upper(), o.initial_points)
                         : log_spaced(objective.lower(), objective.upper(), o.initial_points);
    Index assessments = 0;
    Stagnation stagnation(o.stagnation_window, o.stagnation_ratio);
    auto tail = [&] { return run.shortfall(); };
    // The order budget holds for every assessed model, not only for the predicted growth: the
    // reducer may deliver more columns than p points imply at the start or at an optimum (fewer
    // deflated directions). Such a model is not assessed; the cost is its one reduction.
    const bool reducer_limit = reducer_max <= o.max_order;
    auto over_order = [&](Index delivered, const std::string& what) {
      return finish(
          reducer_limit ? Termination::ReducerExhausted : Termination::MaxOrderReached,
          (reducer_limit ? "the reducer delivers at most order " : "order budget max_order = ") +
              std::to_string(max_order) + " exceeded: " + what + " gave order " +
              std::to_string(delivered) + " (not assessed): " +
              (run.most_accurate() ? tail() : std::string("no model assessed")));
    };
    // Points closer than this in log10 f count as one when growing (as greedy's min_separation
    // default: 1e-3 of the band's log width).
    const double separation = 1e-3 * (objective.upper() - objective.lower());
    auto converged = [&](const std::string& where) {
      // The first passing set usually holds more than the tolerance needs (every point has the
      // same moments, growth adds points where the error peaked): drop what it does not need.
      std::string pruned;
      if (o.prune) {
        const Candidate first = *run.smallest_pass();
        pruned = strategy_support::prune_points(
            run, first.result.points.empty() ? objective.points_of(x) : first.result.points, first,
            std::numeric_limits<Index>::max(), [&](const std::vector<ExpansionPoint>& pts) {
              return strategy_support::reduce_at(*run.context().reducer, pts);
            });
      }
      const Candidate& c = *run.smallest_pass();
      return finish(Termination::Converged, "band error " + sci(c.error.sup_relative) +
                                                " <= tolerance " + sci(ctx.tolerance) +
                                                " at order " + std::to_string(c.order()) +
                                                " with " + std::to_string(c.result.points.size()) +
                                                " points" + where + run.verified_phrase() + pruned);
    };

    // The start may itself be unusable (a point on an eigenvalue): then the optimiser
    // starts from it all the same and steers away (its evaluation counts as a failure).
    Candidate c;
    std::optional<ReducerResult> start;
    try {
      start = objective.reduce(x);
    } catch (const Interrupted&) {
      throw;  // the run's stop request, not a property of x
    } catch (const Error&) {
    }
    if (start && start->V.cols() > max_order) {
      return over_order(start->V.cols(), "the start with " + std::to_string(x.size()) + " points");
    }
    if (start) {
      c = run.assess(std::move(*start), "start",
                     {{"points", static_cast<double>(x.size())},
                      {"samples", static_cast<double>(objective.samples().size())}});
      ++assessments;
      stagnation.record(run.best_error());  // the first record never stagnates
      objective.add_peaks(c.error, peak_count, o.max_added_samples);
      if (c.passed) return converged(" (start points)");
      if (run.stopped()) return finish(Termination::Interrupted, "stopped by request at the start");
    }

    Index reoptimized = 0;  // re-optimisations at the current p
    while (true) {
      if (assessments >= o.max_iterations) {
        return finish(Termination::IterationLimit,
                      "iteration budget max_iterations = " + std::to_string(o.max_iterations) +
                          " (assessed models) used up with " + std::to_string(x.size()) +
                          " points: " + tail());
      }
      objective.begin_round();
      const Optimisation opt = optimise(objective, x);
      if (run.stopped()) {
        return finish(Termination::Interrupted, "stopped by request while optimising " +
                                                    std::to_string(x.size()) + " points");
      }
      if (objective.best_x().empty()) {
        return finish(Termination::Failed,
                      strategy + ": every one of " + std::to_string(objective.round_evaluations()) +
                          " objective evaluations with " + std::to_string(x.size()) +
                          " points failed; last: " + objective.last_failure());
      }
      x = objective.best_x();
      std::map<std::string, double> diag = opt.diagnostics;
      diag["points"] = static_cast<double>(x.size());
      diag["evaluations"] = static_cast<double>(objective.round_evaluations());
      diag["failed_evaluations"] = static_cast<double>(objective.round_failures());
      diag["objective_start"] = objective.start_value();
      diag["objective_optimum"] = objective.best_value();
      diag["samples"] = static_cast<double>(objective.samples().size());
      ReducerResult reduced = objective.reduce(x);
      if (reduced.V.cols() > max_order) {
        return over_order(reduced.V.cols(),
                          "the optimum with " + std::to_string(x.size()) + " points");
      }
      // The optimiser's own report (algorithm, stop reason) goes into the history note.
      if (!opt.status.empty()) reduced.note += (reduced.note.empty() ? "" : "; ") + opt.status;
      c = run.assess(std::move(reduced), "optimum", diag);
      ++assessments;
      const double sample_sup = std::pow(10.0, objective.best_value()) - objective.floor();
      objective.add_peaks(c.error, peak_count, o.max_added_samples);
      if (c.passed) return converged("");
      if (run.stopped()) {
        return finish(Termination::Interrupted, "stopped by request after optimising " +
                                                    std::to_string(x.size()) + " points");
      }
      if (stagnation.record(run.best_error())) {
        return finish(Termination::Stagnated,
                      "band error stagnated at " + sci(stagnation.last()) + " over the last " +
                          std::to_string(stagnation.window()) + " assessed models (" +
                          std::to_string(x.size()) + " points); tolerance " + sci(ctx.tolerance));
      }
      // The full, refined evaluation found much more error than the sample set showed: the
      // optimiser was steered by samples that miss a peak. The peaks are samples now; optimise
      // the same points again before paying for another point.
      if (c.error.sup_relative > 2.0 * sample_sup && reoptimized < o.reoptimize) {
        ++reoptimized;
        continue;
      }
      const Index p = static_cast<Index>(x.size());
      if (p + 1 > o.max_points) {
        return finish(Termination::MaxOrderReached,
                      "point budget max_points = " + std::to_string(o.max_points) +
                          " reached (order " + std::to_string(c.order()) + "): " + tail());
      }
      // Grow: new points where the optimum's error peaks (its supremum first, then other local
      // maxima above the tolerance, up to points_per_growth); the others stay (warm start).
      const Band& band = ctx.estimator->band();
      const std::vector<double> added =
          growth_points(c.error, x, std::min(o.points_per_growth, o.max_points - p), ctx.tolerance,
                        separation, band);
      const Index k = static_cast<Index>(added.size());
      // Each point adds about the same number of columns (2 m per moment for a complex point).
      const Index next_order = c.order() + k * ((c.order() + p - 1) / p);
      if (next_order > max_order) {
        return finish(
            reducer_limit ? Termination::ReducerExhausted : Termination::MaxOrderReached,
            (reducer_limit ? "the reducer delivers at most order " : "order budget max_order = ") +
                std::to_string(max_order) + " would be exceeded by " + std::to_string(p + k) +
                " points (about order " + std::to_string(next_order) + "): " + tail());
      }
      x.insert(x.end(), added.begin(), added.end());
      std::sort(x.begin(), x.end());
      reoptimized = 0;
      // Assess the grown set: it may already pass, saving an optimisation at the same order.
      std::optional<ReducerResult> grown;
      try {
        grown = objective.reduce(x);
      } catch (const Interrupted&) {
        throw;
      } catch (const Error&) {
        // Unusable (a point on an eigenvalue): the optimiser starts there and steers away.
      }
      if (grown && grown->V.cols() > max_order) {
        return over_order(grown->V.cols(),
                          "the grown set with " + std::to_string(x.size()) + " points");
      }
      if (grown) {
        c = run.assess(std::move(*grown), "grow",
                       {{"points", static_cast<double>(x.size())},
                        {"samples", static_cast<double>(objective.samples().size())}});
        ++assessments;
        objective.add_peaks(c.error, peak_count, o.max_added_samples);
        if (c.passed) return converged(" (grown set, before optimising)");
        if (run.stopped()) {
          return finish(Termination::Interrupted, "stopped by request after growing to " +
                                                      std::to_string(x.size()) + " points");
        }
      }
    }
  });
}

}  // namespace ecmor::point_search
