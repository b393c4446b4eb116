#include "point_objective.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "ecmor/base/error.hpp"

namespace ecmor::point_search {

using strategy_support::Candidate;
using strategy_support::sci;

namespace {

// Within one optimisation, an evaluation goes to the history only when it at least halves the
// sample-set error of the last one recorded: log10(2) in F. Enough to see the points move (a
// few lines per decade of improvement), few enough to keep thousands of evaluations out.
constexpr double kRecordGain = 0.30102999566398120;

}  // namespace

const OptionSpecs<PointSearchOptions>& PointSearchOptions::specs() {
  using O = PointSearchOptions;
  static const OptionSpecs<O> specs(
      {
          option("initial_points", &O::initial_points,
                 "number of points at the start (see initial_spacing)")
              .range(Range::closed(1, 1000)),
          choice("initial_spacing", &O::linear_spacing, {{"log", false}, {"linear", true}},
                 "start points at the midpoints of equal sections of [log f_min, log f_max] or of "
                 "[f_min, f_max] (linear: for bands over decades whose resonances crowd the top, a "
                 "chain or a beam)"),
          option("moments", &O::moments, "moments at every point").range(Range::closed(1, 1000)),
          option("max_points", &O::max_points, "point budget, >= initial_points")
              .range(Range::closed(1, 1000)),
          option("max_order", &O::max_order,
                 "order budget, checked on the start and on each optimum before they are "
                 "assessed, and on the predicted order before adding a point")
              .range(Range::at_least(1)),
          option("max_iterations", &O::max_iterations,
                 "assessed models (start, grow and optimum rows; not optimiser trials, not verify "
                 "rows)")
              .range(Range::at_least(1)),
          option("reoptimize", &O::reoptimize,
                 "re-optimisations at one p after the samples missed a peak")
              .range(Range::at_least(0)),
          strategy_support::stagnation_window_option(
              &O::stagnation_window, "assessments without enough gain before stagnated; 0: off"),
          strategy_support::stagnation_ratio_option(
              &O::stagnation_ratio,
              "stagnated when best assessed error >= stagnation_ratio x its value "
              "stagnation_window assessments earlier"),
          // A floor of 0 brings back log10(0) = -inf.
          option("error_floor", &O::error_floor,
                 "floor = error_floor * tolerance, added to eps before the logarithm (a fraction "
                 "of the tolerance)")
              .range(Range::open_closed(0, 1)),
          option("max_added_samples", &O::max_added_samples,
                 "cap on frequencies added to the sample set over the run")
              .range(Range::at_least(0)),
          option("stable_only", &O::stable_only,
                 "an unstable reduced model is a failed evaluation (penalty value for NLopt, a "
                 "failed step for Ipopt): it can never pass, so its band error must not attract "
                 "the search; the reducer's unstable_poles diagnostic is used when it reports "
                 "one, else the poles are computed"),
          option("peaks_per_assessment", &O::peaks_per_assessment,
                 "local error maxima added to the sample set per assessed model; 0 = max(5, "
                 "error.refine_peaks)")
              .range(Range::closed(0, 100000)),
          option("points_per_growth", &O::points_per_growth,
                 "points added when an optimum misses: at its peak and its other largest error "
                 "maxima above the tolerance (bands with dozens of resonances: fewer optimisation "
                 "rounds)")
              .range(Range::closed(1, 1000)),
          option("prune", &O::prune,
                 "after the first pass, drop the points and moments not needed (as "
                 "greedy_points)"),
      },
      {[](const O& o, const OptionCheck<O>& c) {
        if (o.max_points < o.initial_points) {
          c.fail(o.max_points, "must be >= " + c.key(o.initial_points) + " = " +
                                   std::to_string(o.initial_points));
        }
      }});
  return specs;
}

std::vector<double> log_spaced(double lower, double upper, Index p) {
  std::vector<double> x(static_cast<std::size_t>(p));
  for (Index i = 0; i < p; ++i) {
    x[static_cast<std::size_t>(i)] =
        lower + (static_cast<double>(i) + 0.5) * (upper - lower) / static_cast<double>(p);
  }
  return x;
}

std::vector<double> linear_spaced(double lower, double upper, Index p) {
  const double f0 = std::pow(10.0, lower), f1 = std::pow(10.0, upper);
  std::vector<double> x(static_cast<std::size_t>(p));
  for (Index i = 0; i < p; ++i) {
    const double t = (static_cast<double>(i) + 0.5) / static_cast<double>(p);
    x[static_cast<std::size_t>(i)] = std::clamp(std::log10(f0 + t * (f1 - f0)), lower, upper);
  }
  return x;
}

// ---------------------------------------------------------------------------------------------
// PointObjective

PointObjective::PointObjective(strategy_support::StrategyRun& run, Index moments,
                               double error_floor, bool stable_only)
    : m_run(run), m_moments(moments), m_stable_only(stable_only) {
  StrategyContext& ctx = run.context();
  if (ctx.estimator == nullptr || ctx.reducer == nullptr) {
    throw ConfigError("point search: the strategy context has no estimator or no reducer");
  }
  m_floor = error_floor * ctx.tolerance;
  const Band& band = ctx.estimator->band();
  m_lower = std::log10(band.f_min_hz);
  m_upper = std::log10(band.f_max_hz);
  m_samples = ctx.estimator->grid();
  std::sort(m_samples.begin(), m_samples.end());
  m_samples.erase(std::unique(m_samples.begin(), m_samples.end()), m_samples.end());
}

std::vector<ExpansionPoint> PointObjective::points_of(const std::vector<double>& x) const {
  std::vector<ExpansionPoint> points;
  points.reserve(x.size());
  for (double xi : x) {
    points.push_back(point_at_hz(std::pow(10.0, std::clamp(xi, m_lower, m_upper)), m_moments));
  }
  return points;
}

ReducerResult PointObjective::reduce(const std::vector<double>& x) const {
  return strategy_support::reduce_at(*m_run.context().reducer, points_of(x));
}

PointObjective::Levels PointObjective::evaluate(const std::vector<double>& x) {
  return evaluate_at(x, nullptr);
}

PointObjective::Levels PointObjective::evaluate_rows(const std::vector<double>& x,
                                                     const std::vector<Index>& rows) {
  return evaluate_at(x, &rows);
}

PointObjective::Levels PointObjective::evaluate_at(const std::vector<double>& x,
                                                   const std::vector<Index>* rows) {
  Levels out;
  ++m_evaluations;
  ++m_round_evaluations;
  // The frequencies evaluated: every sample, or the rows asked for.
  std::vector<double> partial;
  if (rows != nullptr) {
    partial.reserve(rows->size());
    for (Index k : *rows) partial.push_back(m_samples[static_cast<std::size_t>(k)]);
  }
  const std::vector<double>& f = rows != nullptr ? partial : m_samples;
  std::optional<ReducerResult> reduced;
  BandError error;
  try {
    reduced = reduce(x);
    error = m_run.context().estimator->evaluate_on(reduced->model, f);
  } catch (const Error& e) {
    // A point on an eigenvalue, a singular shifted matrix, a breakdown of the reducer: this x is
    // unusable, the search is not. (Interrupted too: inside an optimiser's callback it cannot
    // end the search directly; the strategy polls the same stop condition between evaluations.)
    out.failure = e.what();
  }
  if (out.failure.empty() && m_stable_only) {
    // The reducer's own count of poles with Re >= 0 when it reports one (krylov does, for every
    // model), else the rule computes the poles.
    const auto it = reduced->diagnostics.find(kUnstablePolesDiagnostic);
    const bool reported = it != reduced->diagnostics.end() && std::isfinite(it->second);
    const ReducedStability stability = strategy_support::judge_stability(
        m_run.context(), reduced->model, reported ? std::lround(it->second) : -1);
    if (!stability.accepted()) out.failure = "unstable reduced model (" + stability.reason + ")";
  }
  if (out.failure.empty()) {
    if (error.reduced_singular) out.failure = "the reduced model has a pole at a sample frequency";
    // evaluate_on samples exactly f (sorted, unique), so its index j is f[j].
    if (error.relative.size() != f.size()) {
      out.failure = "evaluate_on returned " + std::to_string(error.relative.size()) +
                    " samples for " + std::to_string(f.size()) + " frequencies";
    }
  }
  if (out.failure.empty()) {
    // Rows not evaluated stay NaN.
    out.level.assign(m_samples.size(), std::numeric_limits<double>::quiet_NaN());
    double worst = -std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < f.size(); ++j) {
      const std::size_t k = rows != nullptr ? static_cast<std::size_t>((*rows)[j]) : j;
      const double e = error.relative[j];
      if (std::isinf(e) || (!std::isnan(e) && e < 0.0)) {
        out.failure = "non-finite relative error at " + sci(f[j]) + " Hz";
        break;
      }
      // NaN: H vanishes there, the relative error is undefined and cannot be the maximum.
      out.level[k] = std::log10((std::isnan(e) ? 0.0 : e) + m_floor);
      worst = std::max(worst, out.level[k]);
    }
    out.value = worst;
  }
  if (!out.failure.empty()) {
    out.level.clear();
    ++m_failures;
    ++m_round_failures;
    m_last_failure = out.failure;
    return out;
  }
  out.ok = true;
  m_worst_finite = std::max(m_worst_finite, out.value);
  // A partial evaluation's value is only a lower bound on F(x): it cannot be the round's best.
  if (rows != nullptr) return out;
  const bool first = m_best_x.empty();
  if (first) m_start_value = out.value;
  if (first || out.value < m_best_value) {
    m_best_value = out.value;
    m_best_x = x;
    for (double& xi : m_best_x) xi = std::clamp(xi, m_lower, m_upper);
    if (first || out.value <= m_recorded_value - kRecordGain) {
      m_recorded_value = out.value;
      m_run.record_trial(
          "optimize", *reduced, error,
          {{"evaluation", static_cast<double>(m_round_evaluations)}, {"objective", out.value}});
    }
  }
  return out;
}

double PointObjective::value(const std::vector<double>& x) {
  const Levels l = evaluate(x);
  return l.ok ? l.value : penalty();
}

double PointObjective::penalty() const {
  return std::max(m_worst_finite, std::log10(1.0 + m_floor)) + 1.0;
}

std::optional<Matrix> PointObjective::jacobian(const std::vector<double>& x, const Levels& at,
                                               double h, bool central, double active_decades) {
  const std::size_t p = x.size();
  const std::size_t S = m_samples.size();
  // The rows differenced: all of them, or those within active_decades of the largest level when
  // an earlier Jacobian of this round (same samples, same p) supplies the others.
  const bool reuse = active_decades > 0.0 && at.ok && m_last_jacobian &&
                     m_last_jacobian->rows() == static_cast<Index>(S) &&
                     m_last_jacobian->cols() == static_cast<Index>(p);
  std::vector<Index> rows;
  if (reuse) {
    for (std::size_t k = 0; k < S; ++k) {
      if (at.level[k] >= at.value - active_decades) rows.push_back(static_cast<Index>(k));
    }
  } else {
    rows.resize(S);
    for (std::size_t k = 0; k < S; ++k) rows[k] = static_cast<Index>(k);
  }
  Matrix J = reuse ? *m_last_jacobian : Matrix(static_cast<Index>(S), static_cast<Index>(p));
  for (std::size_t i = 0; i < p; ++i) {
    // Which sides fit in the band: a step across a bound would evaluate a clamped (unchanged)
    // point and report a zero derivative.
    const bool up_ok = x[i] + h <= m_upper;
    const bool down_ok = x[i] - h >= m_lower;
    Levels plus, minus;
    auto at_offset = [&](double d) {
      std::vector<double> y = x;
      y[i] += d;
      return reuse ? evaluate_rows(y, rows) : evaluate(y);
    };
    if (central) {
      if (up_ok) plus = at_offset(h);
      if (down_ok) minus = at_offset(-h);
    } else {
      // Forward difference; backward where the forward step leaves the band or fails.
      if (up_ok) plus = at_offset(h);
      if (!plus.ok && down_ok) minus = at_offset(-h);
    }
    for (Index r : rows) {
      const std::size_t k = static_cast<std::size_t>(r);
      double d;
      if (plus.ok && minus.ok) {
        d = (plus.level[k] - minus.level[k]) / (2.0 * h);
      } else if (plus.ok && at.ok) {
        d = (plus.level[k] - at.level[k]) / h;
      } else if (minus.ok && at.ok) {
        d = (at.level[k] - minus.level[k]) / h;
      } else {
        return std::nullopt;
      }
      J(r, static_cast<Index>(i)) = d;
    }
  }
  m_jacobian_rows += static_cast<Index>(rows.size());
  m_jacobian_rows_total += static_cast<Index>(S);
  m_last_jacobian = J;
  return J;
}

Index PointObjective::add_samples(const std::vector<double>& f_hz, Index cap) {
  const Band& band = m_run.context().estimator->band();
  Index added = 0;
  for (double f : f_hz) {
    if (m_added >= cap) break;
    if (!std::isfinite(f)) continue;
    f = std::clamp(f, band.f_min_hz, band.f_max_hz);
    auto it = std::lower_bound(m_samples.begin(), m_samples.end(), f);
    if (it != m_samples.end() && *it == f) continue;
    m_samples.insert(it, f);
    ++m_added;
    ++added;
  }
  return added;
}

Index PointObjective::add_peaks(const BandError& error, Index count, Index cap) {
  // Local maxima of the assessed model's relative error, largest first: where the refined
  // evaluation found error the grid alone would not see.
  std::vector<double> f{error.f_peak_hz};
  const std::vector<double> peaks = largest_local_maxima_hz(error, count);
  f.insert(f.end(), peaks.begin(), peaks.end());
  return add_samples(f, cap);
}

std::vector<double> growth_points(const BandError& error, const std::vector<double>& x, Index count,
                                  double tolerance, double separation, const Band& band) {
  std::vector<double> taken = x;
  std::vector<double> out;
  auto far = [&](double xf) {
    for (double t : taken)
      if (std::abs(xf - t) <= separation) return false;
    return true;
  };
  auto take = [&](double f_hz) {
    const double xf = std::log10(std::clamp(f_hz, band.f_min_hz, band.f_max_hz));
    if (static_cast<Index>(out.size()) >= count || !far(xf)) return;
    out.push_back(xf);
    taken.push_back(xf);
  };
  // The supremum's peak always: on an existing point it still gets one (two interpolation points
  // close together act as a higher moment there).
  out.push_back(std::log10(std::clamp(error.f_peak_hz, band.f_min_hz, band.f_max_hz)));
  taken.push_back(out.back());
  // All local maxima above the tolerance (more than `count`: some fall near existing points).
  for (double f : largest_local_maxima_hz(error, static_cast<Index>(error.f_hz.size()), tolerance))
    take(f);
  return out;
}

void PointObjective::begin_round() {
  m_last_jacobian.reset();
  m_jacobian_rows = 0;
  m_jacobian_rows_total = 0;
  m_round_evaluations = 0;
  m_round_failures = 0;
  m_best_x.clear();
  m_best_value = 0.0;
  m_start_value = 0.0;
  m_recorded_value = 0.0;
}

}  // namespace ecmor::point_search
