#pragma once
/// \file point_search.hpp
/// The outer loop of the point-optimising strategies (optimize_points, minimax_points) around the
/// objective of point_objective.hpp.
///
/// Outer loop (run_point_search). Start with `initial_points` log-spaced points (centres of
/// equal log cells) and assess them ("start"); then repeat: optimise at fixed p (the optimiser is
/// the strategy's), assess the best x found ("optimum": full evaluate() with refinement, then the
/// independent verify() if it meets the tolerance); add that evaluation's local maxima to the
/// sample set; if it passed: Converged. Otherwise, if the full evaluation found an error more than
/// twice the optimiser's sample-set value (the sample set missed a peak), re-optimise at the same
/// p with the new samples (at most `reoptimize` times per p); else grow: add a point at the
/// optimum's peak frequency and, with points_per_growth = k > 1, up to k - 1 more at its other
/// local error maxima above the tolerance (largest first, each more than 1e-3 of the band's log
/// width from every point); the others stay where the optimiser put them (warm start). The grown
/// set is assessed ("grow") before it is optimised. On convergence, with `prune` (default), the
/// passing set is pruned as in greedy_points (strategy_support::prune_points: points, then
/// moments, that the tolerance does not need; phase "prune"), so the result may mix moment counts.
/// Budgets: max_points (MaxOrderReached), max_order (MaxOrderReached; ReducerExhausted when the
/// reducer's own max_order() is the lower cap): checked on the order the reducer delivers for the
/// start and for each optimum before it is assessed (an over-budget model is not assessed), and
/// on the order predicted for p + k points from the current order per point before growing),
/// max_iterations (IterationLimit; counts
/// assessed models, i.e. "start" and "optimum" records, not optimiser trials), stagnation
/// (Stagnated: the best assessed error has not dropped below stagnation_ratio times its value
/// stagnation_window assessments earlier). The history gets: every assessed model with the
/// optimisation's diagnostics (points, evaluations, failed_evaluations, objective_start,
/// objective_optimum, samples, plus the optimiser's own), and sparse "optimize" trials: within
/// one optimisation only evaluations that at least halve the best sample-set error so far, so the
/// points are seen moving without thousands of lines.
///
/// Known limitation. With far too few points (relative error above 1), the error is dominated by
/// spurious resonances of the reduced model, which move with x and which a fixed sample set does
/// not see: the optimisers may then lower the sample-set error while the true error rises (seen
/// with 2 points for 8 resonances). The assessment reports the true error, the best model kept is
/// the most accurate assessed one, and the outer loop re-optimises with the new peaks or grows.
/// If the log-spaced start cannot be reduced (reducer error), it is not assessed; the optimiser
/// starts there all the same and steers away.

#include <string>

#include "ecmor/strategies/strategy.hpp"
#include "point_objective.hpp"

namespace ecmor::point_search {

/// The outer loop shared by optimize_points and minimax_points (see the file comment).
StrategyResult run_point_search(StrategyContext& context, const PointSearchOptions& options,
                                const std::string& strategy, const Optimiser& optimise);

}  // namespace ecmor::point_search
