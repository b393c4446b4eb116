#pragma once
/// \file mixed_basis.hpp
/// mixed_basis: one Galerkin basis of a modal block and Krylov columns at expansion points, for a
/// reducer that takes a modal block (ReducerInfo::modal_block: modal). Modes are cheap and exact
/// where a few dominate the band; a Krylov vector P(i w)^-1 B carries the summed contribution of
/// every mode near w, which wins where many weakly coupled modes crowd the band (issue 29; measured
/// in docs/benchmarks.md).
///
/// Semantics
///  * Block phase (rows "block"): the reducer's models of block_step, 2 block_step, ... columns
///    (ReductionRequest{order, {}}: its ranked modes and static correction). A step *gains* when it
///    lowers the best error so far by at least the fraction `min_gain`. The phase ends after
///    `patience` steps in a row without gain, when the reducer has no more modes, or at
///    block_fraction x max_order (room for points); the block is the smallest order that reached
///    the phase's best error. When more modes only made it worse and the first block did no
///    better than no model at all (error >= 1), the block is empty and the points start with one
///    at the band centre (row "initial").
///  * Point phase: each step tries the `candidates` largest local maxima of the current model's
///    relative error (ReductionRequest{0, points', block}; rows "try_point") and keeps the trial
///    with the lowest error. A peak within min_separation x ln(f_max / f_min) in ln f of a point
///    adds a moment there, any other a new point with `moments` moments. When no trial lowers the
///    error, `fallback_modes` modes are added to the block instead (row "add_modes"). A model
///    passes when it meets the tolerance on the estimator's sampling, on the independent re-check,
///    and is stable; the first pass ends the run (every trial of a step has about the same order).
///
/// Budgets and termination
///  * Converged: a model passed (the smallest passing one is reported).
///  * MaxOrderReached: every next model would exceed `max_order` (or the block reached it).
///  * ReducerExhausted: the reducer ran out of modes before the block gained (block phase only
///    when its best error is the last word: no point can be placed), or delivered no new column.
///  * IterationLimit: `max_iterations` history rows used up (each trial is a row).
///  * Stagnated: the best error did not fall below stagnation_ratio times its value
///    `stagnation_window` point steps earlier (0: never).
///  * Interrupted / Failed: as every strategy (the best model so far is kept).
///
/// Parameters: MixedBasisOptions::specs() (docs/strategies.md prints them).

#include "ecmor/base/options.hpp"
#include "ecmor/strategies/strategy.hpp"

namespace ecmor {

struct MixedBasisOptions {
  Index block_step = 10;           ///< columns added per block step
  double min_gain = 0.1;           ///< a block step gains when it lowers the best error by this
  Index patience = 2;              ///< block steps in a row without gain that end the block phase
  double block_fraction = 0.8;     ///< the block phase ends at this fraction of max_order
  Index candidates = 5;            ///< error peaks tried per point step
  Index moments = 1;               ///< moments at each new point
  double min_separation = 1e-3;    ///< peaks this close (fraction of ln band width) are one point
  Index fallback_modes = 4;        ///< modes added when no candidate lowers the error
  Index max_order = 200;           ///< reduced order budget
  Index max_iterations = 300;      ///< history-row budget (every trial is a row)
  Index stagnation_window = 8;     ///< point steps over which the error must fall (0: never)
  double stagnation_ratio = 0.99;  ///< the best error must fall below ratio x its earlier value

  static const OptionSpecs<MixedBasisOptions>& specs();
  static MixedBasisOptions from(const ParameterMap& params) { return specs().read(params); }
};

class MixedBasis final : public Strategy {
 public:
  explicit MixedBasis(MixedBasisOptions options) : m_options(options) {}
  StrategyResult run(StrategyContext& context) override;
  bool moves_points() const override { return true; }
  bool needs_modal_block() const override { return true; }

 private:
  MixedBasisOptions m_options;
};

}  // namespace ecmor
