#include "prune_points.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <optional>
#include <sstream>

#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"

namespace ecmor::strategy_support {

namespace {

double hz_of(const ExpansionPoint& p) { return p.s.imag() / kTwoPi; }

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

}  // namespace

std::string prune_points(StrategyRun& run, const std::vector<ExpansionPoint>& points,
                         const Candidate& c, Index max_iterations, const PointReduction& reduce) {
  StrategyContext& ctx = run.context();
  BandErrorEstimator& estimator = *ctx.estimator;
  const Index order_before = c.order();
  const std::size_t points_before = points.size();
  const Index moments_before = total_moments(points);
  Index trials = 0;    // point sets screened (one reduction + reduced solves on screen_f)
  Index assessed = 0;  // of them, those that screened below the tolerance: full assessment
  bool cut = false;
  std::string trial_failure;
  auto budget_left = [&] {
    if (run.iterations() >= max_iterations || run.stopped()) cut = true;
    return !cut;
  };

  // The screening set: frequencies whose full response is already in the cache, so that
  // screening a trial costs one reduction and reduced-model solves, no full-model
  // factorisation. It starts as the estimator's grid plus every sample of the passing model's
  // evaluation and re-check (pole samples at its resonances, refinement, the denser
  // independent grid) and gains the local maxima of each assessed trial's error (all its
  // samples would grow the set, and so the cost of every later screen, by ~1000 each).
  std::vector<double> screen_f = estimator.grid();
  std::sort(screen_f.begin(), screen_f.end());
  auto add_screen = [&](std::vector<double> add) {
    std::sort(add.begin(), add.end());
    std::vector<double> merged;
    merged.reserve(screen_f.size() + add.size());
    std::merge(screen_f.begin(), screen_f.end(), add.begin(), add.end(),
               std::back_inserter(merged));
    merged.erase(std::unique(merged.begin(), merged.end()), merged.end());
    screen_f = std::move(merged);
  };
  // An infinite ||H|| marks a frequency where the full model is singular: it is not in the
  // cache and would be factorised (and fail) again at every screen.
  auto cached = [](const BandError& e, std::size_t k) {
    return k < e.reference.size() && std::isfinite(e.reference[k]);
  };
  auto all_samples = [&](const BandError& e) {
    std::vector<double> f;
    for (std::size_t k = 0; k < e.f_hz.size(); ++k)
      if (cached(e, k)) f.push_back(e.f_hz[k]);
    return f;
  };
  auto rel = [](const BandError& e, std::size_t k) {
    return std::isnan(e.relative[k]) ? -1.0 : e.relative[k];
  };
  auto local_maxima = [&](const BandError& e) {
    std::vector<double> f;
    for (std::size_t k = 0; k < e.f_hz.size(); ++k) {
      const double r = rel(e, k);
      if (r < 0.0 || !cached(e, k)) continue;
      if ((k == 0 || rel(e, k - 1) <= r) && (k + 1 == e.f_hz.size() || rel(e, k + 1) < r)) {
        f.push_back(e.f_hz[k]);
      }
    }
    return f;
  };
  // Where the reference (last passing) model's error is largest: a trial that fails usually
  // fails there or near the point it changes, so these are screened first.
  constexpr std::size_t kWorst = 16;
  std::vector<double> worst_f;
  auto note_worst = [&](const BandError& e) {
    std::vector<std::size_t> idx;
    for (std::size_t k = 0; k < e.f_hz.size(); ++k)
      if (rel(e, k) >= 0.0 && cached(e, k)) idx.push_back(k);
    const std::size_t top = std::min(kWorst, idx.size());
    std::partial_sort(idx.begin(), idx.begin() + static_cast<std::ptrdiff_t>(top), idx.end(),
                      [&](std::size_t x, std::size_t y) { return rel(e, x) > rel(e, y); });
    worst_f.clear();
    for (std::size_t j = 0; j < top; ++j) worst_f.push_back(e.f_hz[idx[j]]);
  };
  add_screen(all_samples(c.error));
  note_worst(c.error);
  // The candidate keeps only the larger of its two estimates (evaluate or verify); the other
  // one's samples are recomputed from the cache (same model, same deterministic sampling).
  try {
    const bool holds_verify = c.error.grid_samples != static_cast<Index>(estimator.grid().size());
    add_screen(all_samples(holds_verify ? estimator.evaluate(c.result.model)
                                        : estimator.verify(c.result.model, ctx.verify_factor)));
  } catch (const std::exception&) {
    // Screening then rests on the samples already gathered; nothing is lost but sharpness.
  }

  // The screened error of a trial: sup of the relative error over screen_f. Every frequency
  // there lies in the band, so a screened error above the tolerance proves that the model
  // misses it (the supremum over the band is at least any sampled value): such a trial
  // cannot pass and is not assessed. Below the tolerance it proves nothing (a peak may lie
  // between the samples), so the trial gets the full assessment with its re-check.
  // A screen first evaluates the kNear samples nearest (in log f) to the changed point and
  // the reference model's worst frequencies: most failing trials exceed the tolerance there,
  // and are then ruled out at a few percent of the cost of the whole set (their screened
  // error is then that smaller set's supremum, still a lower bound).
  constexpr std::size_t kNear = 48;
  Index early = 0;  // trials ruled out on the first, small set
  struct Screened {
    double error = std::numeric_limits<double>::infinity();  // inf: broke down / undefined
    Index order = std::numeric_limits<Index>::max();
    std::optional<ReducerResult> result;
  };
  auto first_set = [&](double f_focus) {
    std::vector<double> f = worst_f;
    const auto mid = std::lower_bound(screen_f.begin(), screen_f.end(), f_focus);
    auto lo = mid, hi = mid;  // [lo, hi) taken so far
    while (static_cast<std::size_t>(hi - lo) < std::min(kNear, screen_f.size())) {
      const bool left = lo != screen_f.begin();
      const bool right = hi != screen_f.end();
      if (left && (!right || std::log(f_focus / *(lo - 1)) <= std::log(*hi / f_focus))) {
        --lo;
      } else {
        ++hi;
      }
    }
    f.insert(f.end(), lo, hi);
    return f;
  };
  auto screen = [&](const std::vector<ExpansionPoint>& pts, double f_focus) -> Screened {
    Screened s;
    try {
      ReducerResult r = reduce(pts);
      s.order = r.V.cols();
      const BandError near = estimator.evaluate_on(r.model, first_set(f_focus));
      if (!(near.sup_relative <= ctx.tolerance)) {
        ++early;
        if (!std::isnan(near.sup_relative)) s.error = near.sup_relative;
      } else {
        const BandError e = estimator.evaluate_on(r.model, screen_f);
        if (!std::isnan(e.sup_relative)) s.error = e.sup_relative;
      }
      s.result = std::move(r);
    } catch (const Interrupted&) {
      throw;
    } catch (const std::exception& e) {
      // Plugins may throw anything (guarded() reasons the same way); a trial that breaks down
      // numerically is a failed trial, not the end of a run that already has a passing model.
      if (trial_failure.empty()) trial_failure = e.what();
    }
    return s;
  };
  // Trials are accepted on the estimate (assess without its re-check): each accepted set is a
  // subset of the one before, so only the last needs the re-check, made at the end (step 4).
  // Re-checking every accepted set made 130 of the 195 full solves of the error control on
  // triplechain_mess_n1501_greedy (24 sets).
  std::vector<std::vector<ExpansionPoint>> accepted_sets;
  std::optional<Candidate> last_accepted;
  // One trial: screen, and assess (phase "prune") only if the screen passed.
  auto trial = [&](const std::vector<ExpansionPoint>& pts, double f_focus,
                   std::map<std::string, double> extra) -> bool {
    ++trials;
    Screened s = screen(pts, f_focus);
    if (!s.result || !(s.error <= ctx.tolerance)) return false;
    extra["screened_error"] = s.error;
    extra["screen_samples"] = static_cast<double>(screen_f.size());
    extra["screened_trials"] = static_cast<double>(trials);
    ++assessed;
    try {
      Candidate t = run.assess(std::move(*s.result), "prune", extra, /*verify=*/false);
      add_screen(local_maxima(t.error));
      if (!t.pending && t.stable && misses_on_estimates_only(t.error, ctx.tolerance)) {
        // Above the tolerance only where the error is estimated: the estimate may be high where
        // the reference lacks a full solve. The re-check (full solves where the estimate peaks)
        // decides. Measured on triplechain_mess_n1501_greedy: an estimate of 1.03e-2 at
        // 0.0599 Hz where the true error is 5.3e-3 would have cost the last two states.
        t.pending = true;
        run.confirm(t, extra);
        if (!t.passed) return false;
      } else if (!t.pending) {
        return false;
      }
      note_worst(t.error);
      accepted_sets.push_back(pts);
      last_accepted = std::move(t);
      return true;
    } catch (const Interrupted&) {
      throw;
    } catch (const std::exception& e) {
      if (trial_failure.empty()) trial_failure = e.what();
      return false;
    }
  };
  auto erase = [](std::vector<ExpansionPoint> pts, const std::vector<bool>& drop) {
    std::vector<ExpansionPoint> out;
    for (std::size_t i = 0; i < pts.size(); ++i)
      if (!drop[i]) out.push_back(pts[i]);
    return out;
  };

  // 1. The cost of each point: the screened band error without it (no history records).
  struct Cost {
    std::size_t index;
    double error;      // screened band error without this point (inf: the reduction broke down)
    Index order;       // order without this point
    bool screened_in;  // screened error <= tolerance: the removal may pass
  };
  std::vector<Cost> costs;
  if (points.size() > 1 && budget_left()) {
    for (std::size_t i = 0; i < points.size(); ++i) {
      std::vector<bool> drop(points.size(), false);
      drop[i] = true;
      ++trials;
      const Screened s = screen(erase(points, drop), hz_of(points[i]));
      costs.push_back({i, s.error, s.order, s.error <= ctx.tolerance});
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

  // 2. Remove the points whose single removal screened below the tolerance, cheapest first,
  // each trial on the set left by the accepted removals (screened again on the grown set).
  std::vector<bool> removed(points.size(), false);
  for (const Cost& cost : costs) {
    if (!cost.screened_in) break;  // sorted: none of the rest can pass alone
    if (!budget_left()) break;
    std::vector<bool> drop = removed;
    drop[cost.index] = true;
    // At least one point stays: an empty point set is no model.
    if (std::count(drop.begin(), drop.end(), false) == 0) continue;
    const double f = hz_of(points[cost.index]);
    if (trial(erase(points, drop), f, {{"removed_point_hz", f}})) {
      removed = drop;
    }
  }

  // 3. Fewer moments, cheapest point first (points never costed keep their order).
  std::vector<std::size_t> order;
  for (const Cost& cost : costs) order.push_back(cost.index);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (std::find(order.begin(), order.end(), i) == order.end()) order.push_back(i);
  }
  std::vector<ExpansionPoint> kept_all = points;  // indices stay those of `points`
  for (std::size_t i : order) {
    if (cut) break;
    if (removed[i]) continue;
    while (kept_all[i].moments > 1 && budget_left()) {
      std::vector<ExpansionPoint> candidate = kept_all;
      candidate[i].moments -= 1;
      const double f = hz_of(points[i]);
      if (!trial(erase(candidate, removed), f, {{"reduced_moment_hz", f}})) break;
      kept_all = std::move(candidate);
    }
  }
  // 4. The re-check of the last accepted set. Should it fail (the estimate missed a peak that
  // the re-check's full solves find), the sets accepted before it are re-reduced and assessed
  // with their re-check, newest first, up to kStepsBack of them; the passing model the pruning
  // started from stays the fallback.
  constexpr std::size_t kStepsBack = 2;
  if (last_accepted && !run.stopped()) {
    try {
      run.confirm(*last_accepted);
      bool passed = last_accepted->passed;
      accepted_sets.pop_back();
      for (std::size_t step = 0; !passed && step < kStepsBack && !accepted_sets.empty() &&
                                 !run.stopped();
           ++step) {
        ++assessed;
        passed = run.assess(reduce(accepted_sets.back()), "prune", {{"step_back", 1.0}}).passed;
        accepted_sets.pop_back();
      }
    } catch (const Interrupted&) {
      throw;
    } catch (const std::exception& e) {
      if (trial_failure.empty()) trial_failure = e.what();
    }
  }
  // Describe the reported (smallest passing) model, which need not be the last set tried.
  const Candidate& smallest = *run.smallest_pass();
  std::ostringstream os;
  os << "; pruning: " << points_before << " -> " << smallest.result.points.size() << " points, "
     << moments_before << " -> " << total_moments(smallest.result.points) << " moments, order "
     << order_before << " -> " << smallest.order() << " in " << trials << " trials screened on "
     << screen_f.size() << " cached frequencies (" << early << " ruled out on the " << kNear
     << " nearest and the " << kWorst << " worst), " << assessed << " of them assessed";
  if (cut) os << (run.stopped() ? " (cut short by request)" : " (cut short by max_iterations)");
  if (!trial_failure.empty()) os << " (a trial failed: " << trial_failure << ")";
  return os.str();
}

}  // namespace ecmor::strategy_support
