#pragma once
/// \file optimize_points.hpp
/// optimize_points: move p expansion points (k moments each) to minimise the supremum of the
/// relative band error with a derivative-free NLopt optimiser, and add a point when the optimum
/// still misses the tolerance.
///
/// Semantics. Variables x_i = log10 f_i in [log10 f_min, log10 f_max]; points s_i = i 2 pi f_i.
/// Objective F(x) = log10(max_k eps(f_k; x) + floor) on the sample set of point_objective.hpp
/// (the estimator's grid plus the peaks of every assessed model). One optimisation per point
/// count p, then the outer loop of point_objective.hpp: assess the optimum (full evaluate +
/// independent verify), Converged if it passes, else re-optimise once if the samples missed a
/// peak, else add a point at the optimum's peak frequency (the others stay: warm start).
///
/// Algorithms (`algorithm`):
///  * bobyqa: NLopt LN_BOBYQA (Powell's bound-constrained quadratic-model trust region) from the
///    current points. Local: fast, but finds the basin of the start only.
///  * direct_l: NLopt GN_DIRECT_L (locally biased DIRECT, Gablonsky & Kelley) over the whole box.
///    Global but slow to resolve the last digits.
///  * direct_l_then_bobyqa (default): DIRECT-L with global_fraction of the evaluations, then
///    BOBYQA with the rest from the best point seen (the warm start included: it is evaluated
///    first). The global phase finds the basin, the local one the minimum.
/// A reducer failure at some x is counted and answered with a penalty (one decade above the
/// worst value seen), so the optimiser steers away instead of aborting. An observer stop ends the
/// NLopt run at once (force_stop). NLopt's generic failure (NLOPT_FAILURE, thrown as
/// std::runtime_error: an internal failure, or a non-ecmor exception from the reducer inside the
/// objective) ends only that NLopt run: the best x so far is kept and the status (in the
/// "optimum" row's note) says "FAILURE (...)" with NLopt's message and the objective's.
///
/// Parameters: OptimizePointsOptions::specs() (keys, defaults, ranges; docs/strategies.md prints
/// them), the shared ones from PointSearchOptions.
///
/// Cost. Each evaluation is one reduction at p points (p factorisations unless the reducer caches
/// them) plus S reduced-model solves; an optimisation costs max_evaluations evaluations at most,
/// an assessment one full evaluate() (+ verify() when it passes). The full model's response is
/// computed once per sample frequency (cached).

#include <string>
#include <vector>

#include "ecmor/strategies/strategy.hpp"
#include "point_objective.hpp"
#include "point_search.hpp"

namespace ecmor {

enum class PointAlgorithm { Bobyqa, DirectL, DirectLThenBobyqa };

struct OptimizePointsOptions {
  point_search::PointSearchOptions search;
  PointAlgorithm algorithm = PointAlgorithm::DirectLThenBobyqa;  ///< see the file comment
  Index max_evaluations = 0;                                     ///< per optimisation; 0: 60 p
  double global_fraction = 0.4;  ///< DIRECT-L's share in direct_l_then_bobyqa
  /// direct_l_then_bobyqa runs its global phase only up to this many points; beyond, BOBYQA
  /// alone from the warm start (why: the comment at its spec).
  Index global_max_points = 3;
  double xtol_rel = 1e-4;     ///< step tolerance relative to the band width in decades
  double initial_step = 0.0;  ///< BOBYQA's initial radius in decades; 0: width / (4 p)

  /// Evaluations for p points.
  Index evaluations_for(Index p) const { return max_evaluations > 0 ? max_evaluations : 60 * p; }
  /// Keys, ranges and documentation of the fields above and of `search`.
  static const OptionSpecs<OptimizePointsOptions>& specs();
  /// \throws ConfigError naming the key, its value and the rule.
  static OptimizePointsOptions from(const ParameterMap& params) { return specs().read(params); }
};

/// "bobyqa" | "direct_l" | "direct_l_then_bobyqa".
std::string algorithm_name(PointAlgorithm algorithm);

/// One NLopt optimisation at fixed p from x0 (the warm start is evaluated first), used by
/// OptimizePoints and as minimax_points' presearch. The objective tracks the best x itself.
point_search::Optimisation nlopt_optimise(const OptimizePointsOptions& options,
                                          point_search::PointObjective& objective,
                                          const std::vector<double>& x0);

class OptimizePoints final : public Strategy {
 public:
  explicit OptimizePoints(OptimizePointsOptions options) : m_options(options) {}
  StrategyResult run(StrategyContext& context) override;
  bool moves_points() const override { return true; }

 private:
  OptimizePointsOptions m_options;
};

}  // namespace ecmor
