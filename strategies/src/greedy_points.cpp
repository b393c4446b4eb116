#include "greedy_points.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
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

using strategy_support::hz_of;

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

// The starting points: initial_points (default: the band centre), each inside the band and
// farther than `separation` in |ln f| from the others. \throws ConfigError naming the point.
std::vector<ExpansionPoint> start_points(const GreedyPointsOptions& o, const Band& band,
                                         double separation) {
  std::vector<double> start = o.initial_points_hz;
  if (start.empty()) start.push_back(strategy_support::band_centre_hz(band));
  std::vector<ExpansionPoint> points;
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
        throw ConfigError(std::string("strategy '") + kStrategy + "': initial_points[" +
                          std::to_string(i) + "] = " + number(f) + " Hz and initial_points[" +
                          std::to_string(j) + "] = " + number(start[j]) +
                          " Hz are closer than min_separation = " + number(o.min_separation) +
                          " of the band in log f: give one point with more moments instead");
      }
    }
    points.push_back(point_at_hz(f, o.moments));
  }
  return points;
}

// One growth step with what the history says about it.
struct Step {
  std::vector<ExpansionPoint> points;
  bool adds_point = false;
  std::string phase;  // "add_moment" or "add_point"
  std::string what;   // "a point at 1.2e+01 Hz", for messages
  std::map<std::string, double> extra;
};

// strategy_support::step_toward (the rule) with the history's words for the step.
Step described_step(const std::vector<ExpansionPoint>& points, double f, double separation,
                    Index moments) {
  strategy_support::PointStep s = strategy_support::step_toward(points, f, separation, moments);
  Step step{std::move(s.points), s.adds_point, {}, {}, {}};
  if (s.adds_point) {
    step.phase = "add_point";
    step.what = "a point at " + hz_text(s.at_hz);
    step.extra["added_point_hz"] = s.at_hz;
  } else {
    step.phase = "add_moment";
    step.what =
        "a moment at " + hz_text(s.at_hz) + " (now " + std::to_string(s.moments_there) + ")";
    step.extra["added_moment_hz"] = s.at_hz;
  }
  return step;
}

using strategy_support::Candidate;
using strategy_support::sci;
using strategy_support::Stagnation;

// The run's result when it ends; none while it goes on.
using End = std::optional<StrategyResult>;

// Phase 1: from the start points, add a point (or a moment) where the error peaks until a model
// passes, or end the run with the reason why not.
class Growth {
 public:
  Growth(const GreedyPointsOptions& options, strategy_support::StrategyRun& run, const Band& band,
         double separation)
      : m_o(options),
        m_run(run),
        m_band(band),
        m_separation(separation),
        m_reducer(*run.context().reducer),
        m_max_order(std::min(options.max_order, m_reducer.max_order())),
        m_reducer_caps(m_reducer.max_order() <= options.max_order),
        m_stagnation(options.stagnation_window, options.stagnation_ratio) {}

  // None once a model passed (points() and passed() are then its set and candidate).
  End grow(std::vector<ExpansionPoint> start) {
    ReducerResult first = strategy_support::reduce_at(m_reducer, start);
    m_points = std::move(start);
    m_order = first.V.cols();
    if (m_order > m_max_order) {
      return over_budget(m_order, std::to_string(m_points.size()) + " initial points");
    }
    m_c = m_run.assess(std::move(first), "initial",
                       {{"points", static_cast<double>(m_points.size())}});
    while (true) {
      if (m_run.stopped()) {
        return m_run.finish(Termination::Interrupted,
                            "stopped by request at order " + std::to_string(m_c.order()) +
                                " with " + std::to_string(m_points.size()) +
                                " points; best band error " + sci(m_run.best_error()) +
                                ", tolerance " + sci(tolerance()));
      }
      if (m_c.passed) return std::nullopt;
      if (End end = out_of_budget()) return end;
      if (m_run.escalated()) {
        // The error curve the next point comes from, now against the full model.
        m_c = m_run.assess(m_c.result, "escalate",
                           {{"points", static_cast<double>(m_points.size())}});
        continue;
      }
      // Where the error is worst (the re-check's peak when it found a larger error).
      const double f = next_target(m_c.error, m_blocked);
      if (End end = no_target(f)) return end;
      const double at = std::clamp(f, m_band.f_min_hz, m_band.f_max_hz);
      if (End end = take(described_step(m_points, at, m_separation, m_o.moments), at)) return end;
    }
  }

  const std::vector<ExpansionPoint>& points() const { return m_points; }
  const Candidate& passed() const { return m_c; }

 private:
  double tolerance() { return m_run.context().tolerance; }

  // Stagnation or the iteration budget, checked before each step.
  End out_of_budget() {
    if (m_run.stagnated(m_stagnation)) {
      return m_run.finish(Termination::Stagnated,
                          "band error stagnated at " + sci(m_stagnation.last()) +
                              " over the last " + std::to_string(m_stagnation.window()) +
                              " additions (was " + sci(m_stagnation.before()) + "; order " +
                              std::to_string(m_c.order()) + ", " + std::to_string(m_points.size()) +
                              " points); tolerance " + sci(tolerance()));
    }
    if (m_run.iterations() >= m_o.max_iterations) {
      return m_run.finish(
          Termination::IterationLimit,
          "iteration budget max_iterations = " + std::to_string(m_o.max_iterations) +
              " used up at order " + std::to_string(m_c.order()) + " with " +
              std::to_string(m_points.size()) + " points; " + m_run.shortfall());
    }
    return std::nullopt;
  }

  // The end of the run when next_target found no frequency f to place a point at.
  // \throws NumericalError when the error has no finite peak at all.
  End no_target(double f) {
    if (std::isnan(f) && !m_blocked.empty()) {
      return m_run.finish(Termination::Stagnated,
                          "every frequency left to place a point at spoiled the model (a "
                          "spurious pole on the band; " +
                              std::to_string(m_blocked.size()) + " tried, e.g. " +
                              hz_text(m_blocked.front()) + "); order " +
                              std::to_string(m_c.order()) + "; " + m_run.shortfall());
    }
    if (!std::isfinite(f) || f <= 0.0) {
      throw NumericalError(std::string("strategy '") + kStrategy + "': the band error " +
                           sci(m_c.error.sup_relative) +
                           " has no finite peak frequency (f_peak = " + number(f) +
                           " Hz): cannot place a point");
    }
    return std::nullopt;
  }

  // Reduces and assesses the step toward f; keeps it unless it spoiled the model (then f is
  // blocked and growth goes on from the model before it).
  End take(Step step, double f) {
    if (step.adds_point && static_cast<Index>(m_points.size()) >= m_o.max_points) {
      return m_run.finish(Termination::MaxOrderReached,
                          "point budget max_points = " + std::to_string(m_o.max_points) +
                              " reached (the error peaks at " + hz_text(f) +
                              ", away from every point; order " + std::to_string(m_c.order()) +
                              "); " + m_run.shortfall());
    }
    ReducerResult r = strategy_support::reduce_at(m_reducer, step.points);
    const Index delivered = r.V.cols();
    if (delivered <= m_order) {
      return m_run.finish(Termination::ReducerExhausted,
                          "the reducer returned no new columns for " + step.what + " (order " +
                              std::to_string(delivered) + ", was " + std::to_string(m_order) +
                              "); " + m_run.shortfall());
    }
    if (delivered > m_max_order) return over_budget(delivered, "adding " + step.what);
    step.extra["points"] = static_cast<double>(step.points.size());
    Candidate trial = m_run.assess(std::move(r), step.phase, step.extra);
    if (spoiled(trial.error, m_c.error)) {
      // A spurious pole on the band: keep the model before the step and aim elsewhere.
      m_blocked.push_back(f);
      return std::nullopt;
    }
    m_points = std::move(step.points);
    m_order = delivered;
    m_c = std::move(trial);
    return std::nullopt;
  }

  StrategyResult over_budget(Index delivered, const std::string& what) {
    if (m_reducer_caps) {
      return m_run.finish(Termination::ReducerExhausted,
                          "the reducer delivers at most order " + std::to_string(m_max_order) +
                              ", " + what + " gave order " + std::to_string(delivered) + "; " +
                              m_run.shortfall());
    }
    return m_run.finish(Termination::MaxOrderReached,
                        "order budget max_order = " + std::to_string(m_max_order) +
                            " reached: " + what + " gave order " + std::to_string(delivered) +
                            "; " + m_run.shortfall());
  }

  const GreedyPointsOptions& m_o;
  strategy_support::StrategyRun& m_run;
  const Band m_band;
  const double m_separation;  // frequencies closer than this in |ln f| are one point
  Reducer& m_reducer;
  const Index m_max_order;
  const bool m_reducer_caps;  // the reducer's own maximum is the lower cap
  Stagnation m_stagnation;
  std::vector<ExpansionPoint> m_points;
  Index m_order = 0;  // of the model at m_points
  Candidate m_c;      // the model at m_points, assessed
  // Frequencies where a new point or moment spoiled the model (a spurious pole on the band):
  // such a step is not taken again; growth backs off to the model before it and aims elsewhere.
  std::vector<double> m_blocked;
};

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
          strategy_support::stagnation_window_option(
              &O::stagnation_window,
              "additions over which the error must fall; 0: never stagnates"),
          strategy_support::stagnation_ratio_option(
              &O::stagnation_ratio,
              "stagnated when best error >= stagnation_ratio x its value stagnation_window "
              "additions earlier"),
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

StrategyResult GreedyPoints::run(StrategyContext& ctx) {
  // Configuration problems are the caller's to fix: they throw before any work is done.
  strategy_support::require_point_reducer(ctx, kStrategy);
  if (ctx.estimator == nullptr || ctx.reducer == nullptr) {
    throw ConfigError(std::string("strategy '") + kStrategy + "': no reducer or estimator given");
  }
  const Band band = ctx.estimator->band();
  // Frequencies closer than this in |ln f1 - ln f2| are one point.
  const double separation = m_options.min_separation * std::log(band.f_max_hz / band.f_min_hz);
  std::vector<ExpansionPoint> points = start_points(m_options, band, separation);

  strategy_support::StrategyRun run(ctx);
  return strategy_support::guarded(run, [&]() -> StrategyResult {
    Growth growth(m_options, run, band, separation);
    if (End end = growth.grow(std::move(points))) return std::move(*end);

    // Phase 2: drop what is not needed (order of trials and its cost: see prune_points.hpp).
    std::string prune_note;
    if (m_options.prune) {
      prune_note = strategy_support::prune_points(
          run, growth.points(), growth.passed(), m_options.max_iterations,
          [&](const std::vector<ExpansionPoint>& pts) {
            return strategy_support::reduce_at(*ctx.reducer, pts);
          });
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
