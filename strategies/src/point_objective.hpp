#pragma once
/// \file point_objective.hpp
/// What the point-optimising strategies (optimize_points: NLopt; minimax_points: Ipopt) share: the
/// objective "relative band error as a function of the expansion-point frequencies", its options
/// and the helpers that place points.
///
/// Parametrisation. p expansion points with `moments` moments each sit at s_i = i 2 pi f_i
/// (point_at_hz; a complex point also interpolates at its conjugate). The optimisation variables
/// are x_i = log10(f_i), bounded to [log10 f_min, log10 f_max] of the band: resonances of lightly
/// damped structures are equally "wide" on a log scale, and the bound keeps every point in the
/// band. The reducer is asked for exactly these points: ReductionRequest{0, points}.
///
/// Objective. For one x: reduce, then evaluate the relative error eps(f_k; x) with
/// BandErrorEstimator::evaluate_on on a FIXED sample set f_1..f_S (the full model's response there
/// is cached by the estimator, so an evaluation costs one reduction plus S reduced-model solves):
/// the estimator's log grid plus frequencies added as the run goes (the local maxima found by the
/// full, refined evaluate() of every assessed model), so that an optimiser cannot hide error
/// between samples. Per sample the "level" is
///     L_k(x) = log10(eps(f_k; x) + floor),   floor = error_floor * tolerance,
/// and the objective is F(x) = max_k L_k(x) = log10(max_k eps_k + floor). The logarithm makes a
/// halving of the error the same step anywhere between 1 and 1e-8 (the optimisers see a well
/// scaled function); the floor keeps L_k bounded and smooth near the interpolation points, where
/// eps vanishes and log10(eps) would run to -inf with unbounded derivatives (such samples are far
/// from the maximum and irrelevant to it). Samples where ||H|| vanishes (relative error undefined)
/// count as L_k = log10(floor). A reducer failure at some x (e.g. a point on an undamped
/// eigenvalue, a singular shifted matrix) or a non-finite error is counted, not fatal: the
/// evaluation reports "failed" and the optimisers treat it as a large value / a rejected step.
///
/// The outer loop that optimises at fixed p, assesses and grows: point_search.hpp.

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "ecmor/base/options.hpp"
#include "ecmor/strategies/strategy.hpp"
#include "support.hpp"

namespace ecmor::point_search {

/// Options common to both point-optimising strategies; the initialisers are the defaults, specs()
/// the keys, ranges and documentation.
struct PointSearchOptions {
  Index initial_points = 2;        ///< p at the start (log- or linearly spaced)
  bool linear_spacing = false;     ///< start points equally spaced in f instead of log f
  Index moments = 2;               ///< moments matched per point
  Index max_points = 12;           ///< point budget
  Index max_order = 200;           ///< order budget (columns of V)
  Index max_iterations = 20;       ///< assessed models ("start" + "optimum" records)
  Index reoptimize = 1;            ///< re-optimisations at one p after the samples missed a peak
  Index stagnation_window = 3;     ///< assessments without enough gain before Stagnated (0: off)
  double stagnation_ratio = 0.99;  ///< "enough gain": best < ratio * best `window` earlier
  /// floor = error_floor * tolerance is added to eps before the logarithm.
  double error_floor = 1e-3;
  Index max_added_samples = 400;  ///< cap on sample frequencies added to the estimator's grid
  bool stable_only = true;        ///< an unstable model is a failed evaluation
  Index peaks_per_assessment =
      0;  ///< local error maxima added per assessed model (0: max(5, refine_peaks))
  Index points_per_growth = 1;  ///< points added when an optimum misses
  bool prune = true;            ///< after the first pass, drop the points and moments not needed

  /// Keys, ranges and documentation of the fields above (included by each point search).
  static const OptionSpecs<PointSearchOptions>& specs();
};

/// The objective over log10 point frequencies on a fixed (growing between rounds) sample set.
/// Not thread-safe; owned by one run.
class PointObjective {
 public:
  /// Levels of one evaluation: L_k for every sample (empty when the evaluation failed).
  struct Levels {
    bool ok = false;
    std::vector<double> level;  ///< L_k = log10(eps_k + floor), one per samples()[k]
    double value = 0.0;         ///< max_k L_k (meaningful when ok)
    std::string failure;        ///< why it failed (when !ok)
  };

  /// `run` supplies the reducer, estimator, tolerance and the history. Samples start as the
  /// estimator's grid.
  /// With `stable_only`, an unstable reduced model is a failed evaluation (it can never pass, so
  /// an optimiser must not be drawn towards it by its band error).
  PointObjective(strategy_support::StrategyRun& run, Index moments, double error_floor,
                 bool stable_only = true);

  double lower() const { return m_lower; }  ///< log10 f_min
  double upper() const { return m_upper; }  ///< log10 f_max
  double floor() const { return m_floor; }
  Index moments() const { return m_moments; }

  /// Points i 2 pi 10^x_i (x clamped to the band) with the configured moments.
  std::vector<ExpansionPoint> points_of(const std::vector<double>& x) const;
  /// The reducer's model at x (no counting, no error handling: for assessing an optimum).
  ReducerResult reduce(const std::vector<double>& x) const;

  /// One counted evaluation at x: reduce + evaluate_on(samples). Never throws ecmor::Error (a
  /// failure is returned and counted). Updates the best x of the current round and records
  /// improving trials sparsely (phase "optimize").
  Levels evaluate(const std::vector<double>& x);
  /// F(x) for a minimiser: max_k L_k, or `penalty()` when the evaluation failed.
  double value(const std::vector<double>& x);
  /// A value worse than anything seen: one decade above the largest finite F so far (at least
  /// log10(1 + floor) + 1, i.e. an error of 10).
  double penalty() const;

  /// One counted evaluation at x on the samples `rows` only (indices into samples(), ascending):
  /// level[k] is NaN for the other rows and value is the largest evaluated level. It costs one
  /// reduction and rows.size() reduced solves. Its value is only a lower bound on F(x), so it
  /// never becomes the round's best and is never recorded.
  Levels evaluate_rows(const std::vector<double>& x, const std::vector<Index>& rows);

  /// Finite-difference Jacobian dL_k/dx_i (S x p) at x with step h (decades of f). Central:
  /// (L(x + h e_i) - L(x - h e_i)) / 2h; forward: (L(x + h e_i) - L(x)) / h using `at` (the levels
  /// at x). A coordinate whose +-h leaves the band, or whose perturbed evaluation fails, falls back
  /// to the one-sided difference on the other side. nullopt if both sides of a coordinate fail.
  /// Costs 2p (central) or p (forward) counted evaluations.
  ///
  /// Near-active rows. With active_decades > 0, once a Jacobian of this round exists (same
  /// samples, same p), only the rows whose level at x is within active_decades of the largest are
  /// differenced (the perturbed evaluations solve the reduced model at those samples only); the
  /// other rows keep their values from the last Jacobian. Those are the constraints of the
  /// epigraph program with a large slack, whose multipliers vanish; their values (always exact
  /// in `at`) still enter the line search, so a row that rises is differenced again once it
  /// comes within active_decades.
  std::optional<Matrix> jacobian(const std::vector<double>& x, const Levels& at, double h,
                                 bool central, double active_decades = 0.0);
  /// Jacobian rows differenced in this round, and rows in all its Jacobians.
  Index jacobian_rows() const { return m_jacobian_rows; }
  Index jacobian_rows_total() const { return m_jacobian_rows_total; }

  /// Adds frequencies (Hz, clamped to the band) to the sample set, up to the cap; duplicates are
  /// ignored. Returns how many were added.
  Index add_samples(const std::vector<double>& f_hz, Index cap);
  /// Adds the local maxima of an assessed model's error (largest first, at most `count`) and its
  /// peak frequency.
  Index add_peaks(const BandError& error, Index count, Index cap);
  const std::vector<double>& samples() const { return m_samples; }

  /// Starts a new optimisation round: resets the round's best and its counters (values of
  /// different rounds are not comparable once samples are added).
  void begin_round();
  Index round_evaluations() const { return m_round_evaluations; }
  Index round_failures() const { return m_round_failures; }
  Index evaluations() const { return m_evaluations; }  ///< over the whole run
  Index failures() const { return m_failures; }        ///< over the whole run
  /// Best x of the round (empty if every evaluation failed) and its F.
  const std::vector<double>& best_x() const { return m_best_x; }
  double best_value() const { return m_best_value; }
  /// F of the round's first successful evaluation (the optimiser's start).
  double start_value() const { return m_start_value; }
  /// Last failure message (empty if none).
  const std::string& last_failure() const { return m_last_failure; }
  /// True once the observer asked to stop; optimisers must then end their run.
  bool stopped() const { return m_run.stopped(); }

 private:
  strategy_support::StrategyRun& m_run;
  Index m_moments;
  bool m_stable_only = true;
  double m_floor;
  double m_lower, m_upper;
  std::vector<double> m_samples;  // ascending, unique
  Index m_added = 0;
  Index m_evaluations = 0, m_failures = 0;
  Index m_round_evaluations = 0, m_round_failures = 0;
  std::vector<double> m_best_x;
  double m_best_value = 0.0;
  double m_start_value = 0.0;
  double m_recorded_value = 0.0;  // F of the last trial written to the history in this round
  double m_worst_finite = -1e300;
  std::string m_last_failure;
  std::optional<Matrix> m_last_jacobian;  // of this round (jacobian with active_decades)
  Index m_jacobian_rows = 0, m_jacobian_rows_total = 0;

  Levels evaluate_at(const std::vector<double>& x, const std::vector<Index>* rows);
};

/// What one optimisation at fixed p reports to the outer loop.
struct Optimisation {
  std::string status;                         ///< e.g. "nlopt bobyqa: xtol reached"
  std::map<std::string, double> diagnostics;  ///< optimiser-specific numbers for the history
};

/// An optimiser at fixed p: minimise over x starting from x0 using objective.evaluate/value/
/// jacobian (the objective tracks the best x itself). May throw ecmor::Error only for bugs or
/// configuration problems; evaluation failures are handled by the objective.
using Optimiser =
    std::function<Optimisation(PointObjective& objective, const std::vector<double>& x0)>;

/// Where to add up to `count` points (as log10 f, clamped to the band) when a model with points
/// at x misses the tolerance: always the error's supremum (error.f_peak_hz), then the other local
/// maxima above `tolerance`, largest first, each farther than `separation` (decades) from every
/// point of x and every point already chosen.
std::vector<double> growth_points(const BandError& error, const std::vector<double>& x, Index count,
                                  double tolerance, double separation, const Band& band);

/// p log-spaced frequencies in the band as log10 values: centres of p equal cells in log f.
std::vector<double> log_spaced(double lower, double upper, Index p);
/// x = log10 f of p points at the midpoints of p equal sections of [10^lower, 10^upper] in f.
std::vector<double> linear_spaced(double lower, double upper, Index p);

}  // namespace ecmor::point_search
