#pragma once
/// \file greedy_points.hpp
/// greedy_points: place expansion (interpolation) points where the relative band error is worst,
/// until the model meets the tolerance, then drop what is not needed.
///
/// Semantics
///  * Start: the points `initial_points` (Hz; default: the band centre sqrt(f_min f_max)), each
///    s0 = i 2 pi f with `moments` moments (a complex point also interpolates at its conjugate).
///    The reducer is asked for exactly these points (ReductionRequest::order = 0: no cap) and the
///    model is assessed (phase "initial").
///  * Greedy growth: while the model does not pass, take the frequency f where its relative band
///    error peaks (BandError::f_peak_hz of the estimator's evaluate, including its peak refinement;
///    when the independent re-check found a larger error, its peak). If f lies within
///    `min_separation` of an existing point, measured in log f relative to the band's width,
///        |ln f - ln f_i| <= min_separation * ln(f_max / f_min),
///    one moment is added at the nearest point f_i (phase "add_moment"); otherwise a new point at f
///    with `moments` moments is added (phase "add_point"). A model passes when it meets the
///    tolerance on the estimator's sampling, on the independent denser re-check, and is stable.
///  * Back-off: a step that spoils the model (band error inf, or above both 1 and ten times the
///    error of the model before it: a spurious pole on the band) is recorded but not taken. Growth
///    goes on from the model before it, aiming at the largest finite error more than 5 % in f away
///    from every frequency that gave such a step. When no frequency is left, the run ends Stagnated
///    and says so.
///  * Pruning (phase "prune", `prune: true`), from the first passing point set: points, then
///    moments, that the tolerance does not need are dropped, each trial screened on cached
///    frequencies before it is assessed (strategy_support::prune_points, prune_points.hpp). The
///    smallest passing model seen in any phase is reported.
///
/// Budgets and termination
///  * Converged: a passing model was found (message: error, tolerance, order, points, pruning).
///  * MaxOrderReached: the next model would need more than `max_points` points, or the reducer
///    delivered more than `max_order` columns for it (such a model is not assessed; the cost is
///    that one reduction). When the reducer's own max_order() is the lower cap, the reason is
///    ReducerExhausted instead.
///  * IterationLimit: `max_iterations` history records (including "verify" and "prune") used up;
///    the budget is checked before each new model, whose re-check may add one record beyond it.
///    During pruning it only cuts the pruning short (the result stays Converged).
///  * Stagnated: the best error did not fall below stagnation_ratio times its value
///    `stagnation_window` additions earlier (window 0: never).
///  * ReducerExhausted: an added point or moment gave no new columns (the reducer deflated it).
///  * Interrupted: the observer asked to stop during growth (during pruning the passing model is
///    kept and reported as Converged, with "pruning cut short" in the message).
///  * Failed: numerical breakdown (the best model so far is kept). A prune trial that breaks down
///    only counts as a failed trial (named in the message): a passing model exists already.
///  Every history record carries the points of the reducer's result (the requested points if the
///  reducer returned none).
///
/// Parameters: GreedyPointsOptions::specs() (keys, defaults, ranges; docs/strategies.md prints
/// them).

#include <vector>

#include "ecmor/base/options.hpp"
#include "ecmor/strategies/strategy.hpp"

namespace ecmor {

struct GreedyPointsOptions {
  /// Starting expansion points in Hz (inside the band: checked by run()). Empty: the geometric
  /// band centre.
  std::vector<double> initial_points_hz;
  Index moments = 2;  ///< moments matched at each new point
  /// Two frequencies closer than this fraction of the band's width in log f count as one point.
  /// 0: only an exact coincidence does.
  double min_separation = 1e-3;
  Index max_points = 40;           ///< point budget
  Index max_order = 400;           ///< reduced order budget
  Index max_iterations = 200;      ///< history-record budget (all phases)
  Index stagnation_window = 6;     ///< additions over which the error must fall (0: never)
  double stagnation_ratio = 0.99;  ///< the best error must fall below ratio x its earlier value
  bool prune = true;               ///< after the first pass, drop points and moments not needed

  /// Keys, ranges and documentation of the fields above (stated there, not here).
  static const OptionSpecs<GreedyPointsOptions>& specs();
  /// Reads every option from `params`. \throws ConfigError naming the key, value and rule.
  static GreedyPointsOptions from(const ParameterMap& params) { return specs().read(params); }
};

class GreedyPoints final : public Strategy {
 public:
  explicit GreedyPoints(GreedyPointsOptions options) : m_options(std::move(options)) {}
  /// \throws ConfigError if the reducer does not use expansion points or an initial point lies
  ///         outside the band; everything else ends in a termination reason.
  StrategyResult run(StrategyContext& context) override;
  bool moves_points() const override { return true; }

 private:
  GreedyPointsOptions m_options;
};

}  // namespace ecmor
