#include "prune_points.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <map>
#include <optional>
#include <sstream>

#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"

namespace ecmor::strategy_support {

namespace {

Index total_moments(const std::vector<ExpansionPoint>& points) {
  Index k = 0;
  for (const auto& p : points) k += p.moments;
  return k;
}

// True when the error exceeds the tolerance only at estimated samples: every sample measured
// against the full model's own H is within it (an undefined one is not).
bool misses_on_estimates_only(const BandError& e, double tolerance) {
  if (!e.estimated) return false;
  for (std::size_t k = 0; k < e.f_hz.size(); ++k) {
    const bool exact = k < e.exact.size() && e.exact[k] != 0;
    if (exact && !(e.relative[k] <= tolerance)) return false;
  }
  return true;
}

// An infinite ||H|| marks a frequency where the full model is singular: it is not in the
// cache and would be factorised (and fail) again at every screen.
bool cached(const BandError& e, std::size_t k) {
  return k < e.reference.size() && std::isfinite(e.reference[k]);
}

// The relative error at sample k; -1 where it is undefined.
double rel(const BandError& e, std::size_t k) {
  return std::isnan(e.relative[k]) ? -1.0 : e.relative[k];
}

// Every cached sample of an evaluation.
std::vector<double> all_samples(const BandError& e) {
  std::vector<double> f;
  for (std::size_t k = 0; k < e.f_hz.size(); ++k)
    if (cached(e, k)) f.push_back(e.f_hz[k]);
  return f;
}

// The cached samples where the error has a local maximum.
std::vector<double> local_maxima(const BandError& e) {
  std::vector<double> f;
  for (std::size_t k = 0; k < e.f_hz.size(); ++k) {
    const double r = rel(e, k);
    if (r < 0.0 || !cached(e, k)) continue;
    if ((k == 0 || rel(e, k - 1) <= r) && (k + 1 == e.f_hz.size() || rel(e, k + 1) < r)) {
      f.push_back(e.f_hz[k]);
    }
  }
  return f;
}

// The `count` cached samples where the error is largest.
std::vector<double> worst_samples(const BandError& e, std::size_t count) {
  std::vector<std::size_t> idx;
  for (std::size_t k = 0; k < e.f_hz.size(); ++k)
    if (rel(e, k) >= 0.0 && cached(e, k)) idx.push_back(k);
  const std::size_t top = std::min(count, idx.size());
  std::partial_sort(idx.begin(), idx.begin() + static_cast<std::ptrdiff_t>(top), idx.end(),
                    [&](std::size_t x, std::size_t y) { return rel(e, x) > rel(e, y); });
  std::vector<double> f;
  for (std::size_t j = 0; j < top; ++j) f.push_back(e.f_hz[idx[j]]);
  return f;
}

// The points whose `drop` flag is not set.
std::vector<ExpansionPoint> without(const std::vector<ExpansionPoint>& pts,
                                    const std::vector<bool>& drop) {
  std::vector<ExpansionPoint> out;
  for (std::size_t i = 0; i < pts.size(); ++i)
    if (!drop[i]) out.push_back(pts[i]);
  return out;
}

// Where the reference (last passing) model's error is largest: a trial that fails usually
// fails there or near the point it changes, so these are screened first.
constexpr std::size_t kWorst = 16;
// A screen first evaluates this many samples nearest (in log f) to the changed point.
constexpr std::size_t kNear = 48;
// Accepted sets re-assessed with their re-check when the last one's re-check fails.
constexpr std::size_t kStepsBack = 2;

// The cost of removing one point: the screened band error without it (no history records).
struct Cost {
  std::size_t index;
  double error;      // screened band error without this point (inf: the reduction broke down)
  Index order;       // order without this point
  bool screened_in;  // screened error <= tolerance: the removal may pass
};

// One pruning of a passing point set (prune_points.hpp): the screening set, the trials and
// their counts, and the sets accepted so far.
class Pruning {
 public:
  Pruning(StrategyRun& run, const std::vector<ExpansionPoint>& points, const Candidate& c,
          Index max_iterations, const PointReduction& reduce)
      : m_run(run),
        m_estimator(*run.context().estimator),
        m_tolerance(run.context().tolerance),
        m_max_iterations(max_iterations),
        m_reduce(reduce),
        m_points(points),
        m_moments_before(total_moments(points)),
        m_order_before(c.order()) {
    seed_screen(c);
  }

  // 1. The cost of removing each point, cheapest first.
  std::vector<Cost> costs();
  // 2. Removes the points whose single removal screened within the tolerance, cheapest first,
  // each trial on the set left by the accepted removals. Returns the removed points' flags.
  std::vector<bool> remove_points(const std::vector<Cost>& costs);
  // 3. Fewer moments, cheapest point first (points never costed keep their order).
  void reduce_moments(const std::vector<Cost>& costs, const std::vector<bool>& removed);
  // 4. The re-check of the last accepted set, stepping back when it fails.
  void recheck();
  // The message tail that describes the pruning: "; pruning: 41 -> 33 points, ...".
  std::string note() const;

 private:
  // The outcome of screening one trial.
  struct Screened {
    double error = std::numeric_limits<double>::infinity();  // inf: broke down / undefined
    Index order = std::numeric_limits<Index>::max();
    std::optional<ReducerResult> result;
  };

  bool budget_left() {
    if (m_run.iterations() >= m_max_iterations || m_run.stopped()) m_cut = true;
    return !m_cut;
  }
  void fail_trial(const std::exception& e) {
    if (m_trial_failure.empty()) m_trial_failure = e.what();
  }
  void seed_screen(const Candidate& c);
  void add_screen(std::vector<double> add);
  std::vector<double> first_set(double f_focus) const;
  Screened screen(const std::vector<ExpansionPoint>& pts, double f_focus);
  bool trial(const std::vector<ExpansionPoint>& pts, double f_focus,
             std::map<std::string, double> extra);

  StrategyRun& m_run;
  BandErrorEstimator& m_estimator;
  const double m_tolerance;
  const Index m_max_iterations;
  const PointReduction& m_reduce;
  const std::vector<ExpansionPoint>& m_points;  // the passing set the pruning starts from
  const Index m_moments_before;
  const Index m_order_before;
  // The screening set: frequencies whose full response is already in the cache, so that
  // screening a trial costs one reduction and reduced-model solves, no full-model
  // factorisation. It starts as the estimator's grid plus every sample of the passing model's
  // evaluation and re-check (pole samples at its resonances, refinement, the denser
  // independent grid) and gains the local maxima of each assessed trial's error (all its
  // samples would grow the set, and so the cost of every later screen, by ~1000 each).
  std::vector<double> m_screen_f;
  std::vector<double> m_worst_f;  // the kWorst samples of the reference model
  Index m_trials = 0;    // point sets screened (one reduction + reduced solves on m_screen_f)
  Index m_assessed = 0;  // of them, those that screened below the tolerance: full assessment
  Index m_early = 0;     // trials ruled out on the first, small set
  bool m_cut = false;
  std::string m_trial_failure;
  // Trials are accepted on the estimate (assess without its re-check): each accepted set is a
  // subset of the one before, so only the last needs the re-check, made at the end (step 4).
  // Re-checking every accepted set made 130 of the 195 full solves of the error control on
  // triplechain_mess_n1501_greedy (24 sets).
  std::vector<std::vector<ExpansionPoint>> m_accepted_sets;
  std::optional<Candidate> m_last_accepted;
};

void Pruning::seed_screen(const Candidate& c) {
  m_screen_f = m_estimator.grid();
  std::sort(m_screen_f.begin(), m_screen_f.end());
  add_screen(all_samples(c.error));
  m_worst_f = worst_samples(c.error, kWorst);
  // The candidate keeps only the larger of its two estimates (evaluate or verify); the other
  // one's samples are recomputed from the cache (same model, same deterministic sampling).
  try {
    const bool holds_verify = c.error.grid_samples != static_cast<Index>(m_estimator.grid().size());
    add_screen(all_samples(
        holds_verify ? m_estimator.evaluate(c.result.model)
                     : m_estimator.verify(c.result.model, m_run.context().verify_factor)));
  } catch (const std::exception&) {
    // Screening then rests on the samples already gathered; nothing is lost but sharpness.
  }
}

void Pruning::add_screen(std::vector<double> add) {
  std::sort(add.begin(), add.end());
  std::vector<double> merged;
  merged.reserve(m_screen_f.size() + add.size());
  std::merge(m_screen_f.begin(), m_screen_f.end(), add.begin(), add.end(),
             std::back_inserter(merged));
  merged.erase(std::unique(merged.begin(), merged.end()), merged.end());
  m_screen_f = std::move(merged);
}

// The reference model's worst frequencies and the kNear samples nearest to f_focus.
std::vector<double> Pruning::first_set(double f_focus) const {
  std::vector<double> f = m_worst_f;
  const auto mid = std::lower_bound(m_screen_f.begin(), m_screen_f.end(), f_focus);
  auto lo = mid, hi = mid;  // [lo, hi) taken so far
  while (static_cast<std::size_t>(hi - lo) < std::min(kNear, m_screen_f.size())) {
    const bool left = lo != m_screen_f.begin();
    const bool right = hi != m_screen_f.end();
    if (left && (!right || std::log(f_focus / *(lo - 1)) <= std::log(*hi / f_focus))) {
      --lo;
    } else {
      ++hi;
    }
  }
  f.insert(f.end(), lo, hi);
  return f;
}

// The screened error of a trial: sup of the relative error over m_screen_f. Every frequency
// there lies in the band, so a screened error above the tolerance proves that the model
// misses it (the supremum over the band is at least any sampled value): such a trial
// cannot pass and is not assessed. Below the tolerance it proves nothing (a peak may lie
// between the samples), so the trial gets the full assessment with its re-check.
// A screen first evaluates the kNear samples nearest (in log f) to the changed point and
// the reference model's worst frequencies: most failing trials exceed the tolerance there,
// and are then ruled out at a few percent of the cost of the whole set (their screened
// error is then that smaller set's supremum, still a lower bound).
Pruning::Screened Pruning::screen(const std::vector<ExpansionPoint>& pts, double f_focus) {
  Screened s;
  try {
    ReducerResult r = m_reduce(pts);
    s.order = r.V.cols();
    const BandError near = m_estimator.evaluate_on(r.model, first_set(f_focus));
    if (!(near.sup_relative <= m_tolerance)) {
      ++m_early;
      if (!std::isnan(near.sup_relative)) s.error = near.sup_relative;
    } else {
      const BandError e = m_estimator.evaluate_on(r.model, m_screen_f);
      if (!std::isnan(e.sup_relative)) s.error = e.sup_relative;
    }
    s.result = std::move(r);
  } catch (const Interrupted&) {
    throw;
  } catch (const std::exception& e) {
    // Plugins may throw anything (guarded() reasons the same way); a trial that breaks down
    // numerically is a failed trial, not the end of a run that already has a passing model.
    fail_trial(e);
  }
  return s;
}

// One trial: screen, and assess (phase "prune") only if the screen passed.
bool Pruning::trial(const std::vector<ExpansionPoint>& pts, double f_focus,
                    std::map<std::string, double> extra) {
  ++m_trials;
  Screened s = screen(pts, f_focus);
  if (!s.result || !(s.error <= m_tolerance)) return false;
  extra["screened_error"] = s.error;
  extra["screen_samples"] = static_cast<double>(m_screen_f.size());
  extra["screened_trials"] = static_cast<double>(m_trials);
  ++m_assessed;
  try {
    Candidate t = m_run.assess(std::move(*s.result), "prune", extra, /*verify=*/false);
    add_screen(local_maxima(t.error));
    if (!t.pending && t.stable && misses_on_estimates_only(t.error, m_tolerance)) {
      // Above the tolerance only where the error is estimated: the estimate may be high where
      // the reference lacks a full solve. The re-check (full solves where the estimate peaks)
      // decides. Measured on triplechain_mess_n1501_greedy: an estimate of 1.03e-2 at
      // 0.0599 Hz where the true error is 5.3e-3 would have cost the last two states.
      t.pending = true;
      m_run.confirm(t, extra);
      if (!t.passed) return false;
    } else if (!t.pending) {
      return false;
    }
    m_worst_f = worst_samples(t.error, kWorst);
    m_accepted_sets.push_back(pts);
    m_last_accepted = std::move(t);
    return true;
  } catch (const Interrupted&) {
    throw;
  } catch (const std::exception& e) {
    fail_trial(e);
    return false;
  }
}

std::vector<Cost> Pruning::costs() {
  const std::vector<ExpansionPoint>& points = m_points;
  std::vector<Cost> costs;
  if (points.size() > 1 && budget_left()) {
    for (std::size_t i = 0; i < points.size(); ++i) {
      std::vector<bool> drop(points.size(), false);
      drop[i] = true;
      ++m_trials;
      const Screened s = screen(without(points, drop), hz_of(points[i]));
      costs.push_back({i, s.error, s.order, s.error <= m_tolerance});
    }
  }
  // Cheapest first: removals that may pass before those that cannot, then the removal leaving
  // the smaller model (a point whose columns partly deflated frees fewer), then the smaller
  // screened error.
  std::stable_sort(costs.begin(), costs.end(), [](const Cost& a, const Cost& b) {
    if (a.screened_in != b.screened_in) return a.screened_in;
    if (a.order != b.order) return a.order < b.order;
    return a.error < b.error;
  });
  return costs;
}

std::vector<bool> Pruning::remove_points(const std::vector<Cost>& costs) {
  const std::vector<ExpansionPoint>& points = m_points;
  std::vector<bool> removed(points.size(), false);
  for (const Cost& cost : costs) {
    if (!cost.screened_in) break;  // sorted: none of the rest can pass alone
    if (!budget_left()) break;
    std::vector<bool> drop = removed;
    drop[cost.index] = true;
    // At least one point stays: an empty point set is no model.
    if (std::count(drop.begin(), drop.end(), false) == 0) continue;
    const double f = hz_of(points[cost.index]);
    if (trial(without(points, drop), f, {{"removed_point_hz", f}})) {
      removed = drop;
    }
  }
  return removed;
}

void Pruning::reduce_moments(const std::vector<Cost>& costs, const std::vector<bool>& removed) {
  const std::vector<ExpansionPoint>& points = m_points;
  std::vector<std::size_t> order;
  for (const Cost& cost : costs) order.push_back(cost.index);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (std::find(order.begin(), order.end(), i) == order.end()) order.push_back(i);
  }
  std::vector<ExpansionPoint> kept_all = points;  // indices stay those of `points`
  for (std::size_t i : order) {
    if (m_cut) break;
    if (removed[i]) continue;
    while (kept_all[i].moments > 1 && budget_left()) {
      std::vector<ExpansionPoint> candidate = kept_all;
      candidate[i].moments -= 1;
      const double f = hz_of(points[i]);
      if (!trial(without(candidate, removed), f, {{"reduced_moment_hz", f}})) break;
      kept_all = std::move(candidate);
    }
  }
}

// Should the re-check fail (the estimate missed a peak that the re-check's full solves find),
// the sets accepted before it are re-reduced and assessed with their re-check, newest first, up
// to kStepsBack of them; the passing model the pruning started from stays the fallback.
void Pruning::recheck() {
  if (!m_last_accepted || m_run.stopped()) return;
  try {
    m_run.confirm(*m_last_accepted);
    bool passed = m_last_accepted->passed;
    m_accepted_sets.pop_back();
    for (std::size_t step = 0;
         !passed && step < kStepsBack && !m_accepted_sets.empty() && !m_run.stopped(); ++step) {
      ++m_assessed;
      passed = m_run.assess(m_reduce(m_accepted_sets.back()), "prune", {{"step_back", 1.0}}).passed;
      m_accepted_sets.pop_back();
    }
  } catch (const Interrupted&) {
    throw;
  } catch (const std::exception& e) {
    fail_trial(e);
  }
}

// Describes the reported (smallest passing) model, which need not be the last set tried.
std::string Pruning::note() const {
  const Candidate& smallest = *m_run.smallest_pass();
  std::ostringstream os;
  os << "; pruning: " << m_points.size() << " -> " << smallest.result.points.size() << " points, "
     << m_moments_before << " -> " << total_moments(smallest.result.points) << " moments, order "
     << m_order_before << " -> " << smallest.order() << " in " << m_trials << " trials screened on "
     << m_screen_f.size() << " cached frequencies (" << m_early << " ruled out on the " << kNear
     << " nearest and the " << kWorst << " worst), " << m_assessed << " of them assessed";
  if (m_cut) os << (m_run.stopped() ? " (cut short by request)" : " (cut short by max_iterations)");
  if (!m_trial_failure.empty()) os << " (a trial failed: " << m_trial_failure << ")";
  return os.str();
}

}  // namespace

std::string prune_points(StrategyRun& run, const std::vector<ExpansionPoint>& points,
                         const Candidate& c, Index max_iterations, const PointReduction& reduce) {
  Pruning pruning(run, points, c, max_iterations, reduce);
  const std::vector<Cost> costs = pruning.costs();
  const std::vector<bool> removed = pruning.remove_points(costs);
  pruning.reduce_moments(costs, removed);
  pruning.recheck();
  return pruning.note();
}

}  // namespace ecmor::strategy_support
