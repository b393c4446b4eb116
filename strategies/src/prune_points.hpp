#pragma once
/// \file prune_points.hpp
/// Dropping the expansion points and moments a passing model does not need. Shared by the
/// point-placing strategies (greedy_points, optimize_points, minimax_points): each grows a point
/// set until it passes, usually with more points and moments than the tolerance requires.
///
/// From the passing set, every trial (a set with a point or a moment fewer) is first *screened*:
/// the reduced model is evaluated with BandErrorEstimator::evaluate_on on frequencies whose full
/// response is already cached (the estimator's grid, every sample of the passing model's evaluate
/// and verify: pole samples, refinement, the denser independent grid; plus the local maxima of the
/// error of each assessed trial). All lie in the band, so a screened error above the tolerance
/// proves the trial misses it: it is not assessed and leaves no history row. Only a trial screening
/// at or below the tolerance is assessed (estimator evaluate; phase "prune", with diagnostics
/// screened_error, screen_samples, screened_trials) and accepted when it meets the tolerance
/// there. The independent re-check is made once, for the last accepted set (a "verify" row); if it
/// fails, the sets accepted before it are re-reduced and assessed with their re-check, newest
/// first, up to two (diagnostic step_back). A trial missing the tolerance only at estimated
/// samples gets its re-check at once (the estimate may be high where no full solve is near). A
/// screen first evaluates the 48 samples nearest (in log f) to the changed point and the 16
/// frequencies where the last passing model's error is largest; it evaluates the whole set only if
/// those stay within the tolerance.
///  1. removal costs: for each point, the model without it is screened (skipped when there is a
///     single point). Cheapest first means: removals that screen within the tolerance before those
///     that do not, then the one leaving the smaller model, then the smaller screened error;
///  2. removal: the points whose single removal screened within the tolerance are removed one at a
///     time, cheapest first, each trial (screened, then assessed) on the set left by the accepted
///     removals; a point whose single removal screened above the tolerance is kept without a
///     further trial (accuracy is not monotone in the point set, but nearly so);
///  3. moments: for each remaining point (cheapest first) with more than one moment, moments are
///     reduced one at a time while the model still passes.
/// Cost: at most P + (P - 1) + sum_i (k_i - 1) screens for P points with k_i moments, each one
/// reduction plus reduced-model solves at the screened frequencies (no full-model factorisation);
/// a full assessment only for trials that screen within the tolerance. The run's smallest passing
/// candidate is the result (StrategyRun tracks it); pruning stops early when the history reaches
/// `max_iterations` rows or a stop is requested. A trial that breaks down (any exception) counts
/// as a failed trial and is named in the note: a passing model exists already.

#include <functional>
#include <string>
#include <vector>

#include "support.hpp"

namespace ecmor::strategy_support {

/// Reduces at exactly the given points (ReductionRequest{0, points}; the result's points filled
/// in).
using PointReduction = std::function<ReducerResult(const std::vector<ExpansionPoint>&)>;

/// Prunes `points` (the point set of the passing candidate `passing`, points on the imaginary
/// axis). Returns the note for the final message, "; pruning: 41 -> 33 points, ... assessed".
std::string prune_points(StrategyRun& run, const std::vector<ExpansionPoint>& points,
                         const Candidate& passing, Index max_iterations,
                         const PointReduction& reduce);

}  // namespace ecmor::strategy_support
