#include "greedy_points.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "ecmor/base/error.hpp"
#include "prune_points.hpp"
#include "support.hpp"

namespace ecmor {

namespace {

constexpr const char* kStrategy = "greedy_points";

std::string number(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

double hz_of(const ExpansionPoint& p) { return p.s.imag() / kTwoPi; }

std::string hz_text(double f) { return strategy_support::sci(f) + " Hz"; }

// A step that spoiled the model is not taken again near its frequency: within this distance in
// |ln f| (5 %), which covers the resonance hump of any lightly damped mode (half-width zeta f).
constexpr double kBlockedRadius = 0.048790164169432;  // ln(1.05)

bool near_any(double f, const std::vector<double>& frequencies, double radius) {
  return std::any_of(frequencies.begin(), frequencies.end(),
                     [&](double g) { return std::abs(std::log(f / g)) <= radius; });
}

// A step spoiled the model when its error is not finite (a reduced pole on a sample) or exceeds
// both 1, the error of no model at all, and ten times the error of the model before it: a
// spurious pole on the band, not the ordinary unevenness of greedy growth.
bool spoiled(const BandError& trial, const BandError& before) {
  const double e = trial.sup_relative;
  if (!std::isfinite(before.sup_relative)) return false;
  return !std::isfinite(e) || (e > 1.0 && e > 10.0 * before.sup_relative);
}

// Where the next point goes: the error's peak, unless a step near it spoiled the model
// (`blocked`); then the largest finite error away from every blocked frequency. NaN when no
// sample is left.
double next_target(const BandError& error, const std::vector<double>& blocked) {
  const double peak = error.f_peak_hz;
  if (!(std::isfinite(peak) && peak > 0.0)) return peak;
  if (!near_any(peak, blocked, kBlockedRadius)) return peak;
  double best_f = std::numeric_limits<double>::quiet_NaN();
  double best_e = -1.0;
  for (std::size_t k = 0; k < error.f_hz.size() && k < error.relative.size(); ++k) {
    const double e = error.relative[k];
    if (std::isfinite(e) && e > best_e && !near_any(error.f_hz[k], blocked, kBlockedRadius)) {
      best_e = e;
      best_f = error.f_hz[k];
    }
  }
  return best_f;
}

}  // namespace

const OptionSpecs<GreedyPointsOptions>& GreedyPointsOptions::specs() {
  using O = GreedyPointsOptions;
  static const OptionSpecs<O> specs(
      {
          option("initial_points", &O::initial_points_hz,
                 "starting points, inside the band (checked by the run); a single number is a "
                 "list of one; empty: the band centre sqrt(f_min f_max)")
              .unit("Hz")
              .range(Range::above(0).finite()),
          option("moments", &O::moments, "moments at each new point").range(Range::at_least(1)),
          option("min_separation", &O::min_separation,
                 "fraction of the band's width in ln f within which a peak counts as on an "
                 "existing point; 0: only exact coincidence")
              .range(Range::closed_open(0, 1)),
          option("max_points", &O::max_points, "point budget, >= the number of initial_points")
              .range(Range::at_least(1)),
          option("max_order", &O::max_order, "reduced order budget").range(Range::at_least(1)),
          option("max_iterations", &O::max_iterations,
                 "history-row budget over all phases (including verify and prune)")
              .range(Range::at_least(1)),
          option("stagnation_window", &O::stagnation_window,
                 "additions over which the error must fall; 0: never stagnates")
              .range(Range::at_least(0)),
          // Ratios of 0 would make every step "stagnated".
          option("stagnation_ratio", &O::stagnation_ratio,
                 "stagnated when best error >= stagnation_ratio x its value stagnation_window "
                 "additions earlier")
              .range(Range::open_closed(0, 1)),
          option("prune", &O::prune, "drop the points and moments not needed after the first pass"),
      },
      {[](const O& o, const OptionCheck<O>& c) {
        if (static_cast<std::size_t>(o.max_points) < o.initial_points_hz.size()) {
          c.fail(o.max_points, "must be >= the number of " + c.key(o.initial_points_hz) + " (" +
                                   std::to_string(o.initial_points_hz.size()) + ")");
        }
      }});
  return specs;
}

using strategy_support::Candidate;
using strategy_support::sci;
using strategy_support::Stagnation;

StrategyResult GreedyPoints::run(StrategyContext& ctx) {
  // Configuration problems are the caller's to fix: they throw before any work is done.
  strategy_support::require_point_reducer(ctx, kStrategy);
  if (ctx.estimator == nullptr || ctx.reducer == nullptr) {
    throw ConfigError(std::string("strategy '") + kStrategy + "': no reducer or estimator given");
  }
  const Band band = ctx.estimator->band();
  // Frequencies closer than this in |ln f1 - ln f2| are one point.
  const double separation = m_options.min_separation * std::log(band.f_max_hz / band.f_min_hz);
  std::vector<ExpansionPoint> points;
  {
    std::vector<double> start = m_options.initial_points_hz;
    if (start.empty()) start.push_back(strategy_support::band_centre_hz(band));
    for (std::size_t i = 0; i < start.size(); ++i) {
      const double f = start[i];
      if (f < band.f_min_hz || f > band.f_max_hz) {
        throw ConfigError(std::string("strategy '") + kStrategy + "': initial_points[" +
                          std::to_string(i) + "] = " + number(f) + " Hz lies outside the band [" +
                          number(band.f_min_hz) + ", " + number(band.f_max_hz) +
                          "] Hz: points must lie in the band");
      }
      for (std::size_t j = 0; j < i; ++j) {
        if (std::abs(std::log(f / start[j])) <= separation) {
          throw ConfigError(
              std::string("strategy '") + kStrategy + "': initial_points[" + std::to_string(i) +
              "] = " + number(f) + " Hz and initial_points[" + std::to_string(j) +
              "] = " + number(start[j]) +
              " Hz are closer than min_separation = " + number(m_options.min_separation) +
              " of the band in log f: give one point with more moments instead");
        }
      }
      points.push_back(point_at_hz(f, m_options.moments));
    }
  }

  strategy_support::StrategyRun run(ctx);
  Reducer& reducer = *ctx.reducer;
  const Index max_order = std::min(m_options.max_order, reducer.max_order());
  const bool reducer_caps = reducer.max_order() <= m_options.max_order;
  const Index max_iterations = m_options.max_iterations;

  auto reduce = [&](const std::vector<ExpansionPoint>& pts) {
    return strategy_support::reduce_at(reducer, pts);
  };
  auto shortfall = [&]() { return run.shortfall(); };
  auto over_budget = [&](Index delivered, const std::string& what) {
    if (reducer_caps) {
      return run.finish(Termination::ReducerExhausted,
                        "the reducer delivers at most order " + std::to_string(max_order) + ", " +
                            what + " gave order " + std::to_string(delivered) + "; " + shortfall());
    }
    return run.finish(Termination::MaxOrderReached,
                      "order budget max_order = " + std::to_string(max_order) + " reached: " +
                          what + " gave order " + std::to_string(delivered) + "; " + shortfall());
  };

  return strategy_support::guarded(run, [&]() -> StrategyResult {
    // Phase 1: add points (or moments) where the error peaks until a verified, stable pass.
    ReducerResult first = reduce(points);
    Index previous = first.V.cols();
    if (previous > max_order) {
      return over_budget(previous, std::to_string(points.size()) + " initial points");
    }
    Candidate c =
        run.assess(std::move(first), "initial", {{"points", static_cast<double>(points.size())}});
    Stagnation stagnation(m_options.stagnation_window, m_options.stagnation_ratio);
    // Frequencies where a new point or moment spoiled the model (a spurious pole on the band):
    // such a step is not taken; growth backs off to the model before it and aims elsewhere.
    std::vector<double> blocked;
    while (true) {
      if (run.stopped()) {
        return run.finish(Termination::Interrupted,
                          "stopped by request at order " + std::to_string(c.order()) + " with " +
                              std::to_string(points.size()) + " points; best band error " +
                              sci(run.best_error()) + ", tolerance " + sci(ctx.tolerance));
      }
      if (c.passed) break;
      if (stagnation.record(run.best_error())) {
        return run.finish(Termination::Stagnated,
                          "band error stagnated at " + sci(stagnation.last()) + " over the last " +
                              std::to_string(stagnation.window()) + " additions (was " +
                              sci(stagnation.before()) + "; order " + std::to_string(c.order()) +
                              ", " + std::to_string(points.size()) + " points); tolerance " +
                              sci(ctx.tolerance));
      }
      if (run.iterations() >= max_iterations) {
        return run.finish(Termination::IterationLimit,
                          "iteration budget max_iterations = " + std::to_string(max_iterations) +
                              " used up at order " + std::to_string(c.order()) + " with " +
                              std::to_string(points.size()) + " points; " + shortfall());
      }
      // Where the error is worst (the re-check's peak when it found a larger error).
      double f = next_target(c.error, blocked);
      if (std::isnan(f) && !blocked.empty()) {
        return run.finish(Termination::Stagnated,
                          "every frequency left to place a point at spoiled the model (a "
                          "spurious pole on the band; " +
                              std::to_string(blocked.size()) + " tried, e.g. " +
                              hz_text(blocked.front()) + "); order " +
                              std::to_string(c.order()) + "; " + shortfall());
      }
      if (!std::isfinite(f) || f <= 0.0) {
        throw NumericalError(std::string("strategy '") + kStrategy + "': the band error " +
                             sci(c.error.sup_relative) +
                             " has no finite peak frequency (f_peak = " + number(f) +
                             " Hz): cannot place a point");
      }
      f = std::clamp(f, band.f_min_hz, band.f_max_hz);
      std::size_t nearest = 0;
      double distance = std::numeric_limits<double>::infinity();
      for (std::size_t i = 0; i < points.size(); ++i) {
        const double d = std::abs(std::log(f / hz_of(points[i])));
        if (d < distance) {
          distance = d;
          nearest = i;
        }
      }
      std::vector<ExpansionPoint> next = points;
      std::string phase, what;
      std::map<std::string, double> extra;
      if (distance <= separation) {
        // The peak sits on an existing point: interpolating there again would add nothing, a
        // higher moment improves the match around it.
        next[nearest].moments += 1;
        phase = "add_moment";
        what = "a moment at " + hz_text(hz_of(next[nearest])) + " (now " +
               std::to_string(next[nearest].moments) + ")";
        extra["added_moment_hz"] = hz_of(next[nearest]);
      } else {
        if (static_cast<Index>(points.size()) >= m_options.max_points) {
          return run.finish(Termination::MaxOrderReached,
                            "point budget max_points = " + std::to_string(m_options.max_points) +
                                " reached (the error peaks at " + hz_text(f) +
                                ", away from every point; order " + std::to_string(c.order()) +
                                "); " + shortfall());
        }
        next.push_back(point_at_hz(f, m_options.moments));
        phase = "add_point";
        what = "a point at " + hz_text(f);
        extra["added_point_hz"] = f;
      }
      ReducerResult r = reduce(next);
      const Index delivered = r.V.cols();
      if (delivered <= previous) {
        return run.finish(Termination::ReducerExhausted,
                          "the reducer returned no new columns for " + what + " (order " +
                              std::to_string(delivered) + ", was " + std::to_string(previous) +
                              "); " + shortfall());
      }
      if (delivered > max_order) return over_budget(delivered, "adding " + what);
      extra["points"] = static_cast<double>(next.size());
      Candidate trial = run.assess(std::move(r), phase, extra);
      if (spoiled(trial.error, c.error)) {
        // A spurious pole on the band: keep the model before the step and aim elsewhere.
        blocked.push_back(f);
        continue;
      }
      points = std::move(next);
      previous = delivered;
      c = std::move(trial);
    }

    // Phase 2: drop what is not needed (order of trials and its cost: see prune_points.hpp).
    std::string prune_note;
    if (m_options.prune) {
      prune_note = strategy_support::prune_points(run, points, c, max_iterations, reduce);
    }
    const Candidate& best = *run.smallest_pass();
    return run.finish(Termination::Converged,
                      "band error " + sci(best.error.sup_relative) + " <= tolerance " +
                          sci(ctx.tolerance) + " at order " + std::to_string(best.order()) +
                          " with " + std::to_string(best.result.points.size()) + " points" +
                          run.verified_phrase() + prune_note);
  });
}

}  // namespace ecmor
