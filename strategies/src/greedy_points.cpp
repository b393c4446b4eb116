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

std::string owner_prefix(const ParameterMap* p, const std::string& key) {
  std::string prefix;
  if (p != nullptr && !p->location(key).empty()) prefix = p->location(key) + ": ";
  return prefix + "strategy '" + kStrategy + "': ";
}

std::string number(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

// The rules of GreedyPointsOptions; `p` (may be null) only adds the YAML location to messages.
void check(const GreedyPointsOptions& o, const ParameterMap* p) {
  auto fail = [&](const std::string& key, const std::string& what) {
    throw ConfigError(owner_prefix(p, key) + what);
  };
  for (std::size_t i = 0; i < o.initial_points_hz.size(); ++i) {
    const double f = o.initial_points_hz[i];
    if (!std::isfinite(f) || f <= 0.0) {
      fail("initial_points", "initial_points[" + std::to_string(i) + "] = " + number(f) +
                                 ": must be a finite frequency > 0 Hz");
    }
  }
  if (o.moments < 1) fail("moments", "moments = " + std::to_string(o.moments) + ": must be >= 1");
  if (!(o.min_separation >= 0.0 && o.min_separation < 1.0)) {
    fail("min_separation", "min_separation = " + number(o.min_separation) + ": must be in [0, 1)");
  }
  if (o.max_points < 1) {
    fail("max_points", "max_points = " + std::to_string(o.max_points) + ": must be >= 1");
  }
  if (static_cast<std::size_t>(o.max_points) < o.initial_points_hz.size()) {
    fail("max_points", "max_points = " + std::to_string(o.max_points) +
                           ": must be >= the number of initial_points (" +
                           std::to_string(o.initial_points_hz.size()) + ")");
  }
  if (o.max_order < 1) {
    fail("max_order", "max_order = " + std::to_string(o.max_order) + ": must be >= 1");
  }
  if (o.max_iterations < 1) {
    fail("max_iterations",
         "max_iterations = " + std::to_string(o.max_iterations) + ": must be >= 1");
  }
  if (o.stagnation_window < 0) {
    fail("stagnation_window",
         "stagnation_window = " + std::to_string(o.stagnation_window) + ": must be >= 0");
  }
  if (!(o.stagnation_ratio > 0.0 && o.stagnation_ratio <= 1.0)) {
    fail("stagnation_ratio",
         "stagnation_ratio = " + number(o.stagnation_ratio) + ": must be in (0, 1]");
  }
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

GreedyPointsOptions GreedyPointsOptions::from(const ParameterMap& p) {
  GreedyPointsOptions o;
  o.initial_points_hz = p.get_doubles("initial_points", o.initial_points_hz);
  o.moments = p.get_int("moments", o.moments);
  o.min_separation = p.get_double("min_separation", o.min_separation);
  o.max_points = p.get_int("max_points", o.max_points);
  o.max_order = p.get_int("max_order", o.max_order);
  o.max_iterations = p.get_int("max_iterations", o.max_iterations);
  o.stagnation_window = p.get_int("stagnation_window", o.stagnation_window);
  o.stagnation_ratio = p.get_double("stagnation_ratio", o.stagnation_ratio);
  o.prune = p.get_bool("prune", o.prune);
  check(o, &p);
  return o;
}

void GreedyPointsOptions::validate() const { check(*this, nullptr); }

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
