#pragma once
/// \file minimax_points.hpp
/// minimax_points: the point-placement problem of optimize_points as a smooth constrained program
/// solved by Ipopt (interior point, C++ TNLP interface), and a point added when the optimum still
/// misses the tolerance.
///
/// Semantics. Variables (x_1..x_p, t) with x_i = log10 f_i in [log10 f_min, log10 f_max] (points
/// s_i = i 2 pi f_i) and t free:
///     minimise t   subject to   L_k(x) - t <= 0   for every sample frequency f_k,
/// L_k(x) = log10(eps(f_k; x) + floor) on the sample set of point_objective.hpp (estimator grid +
/// peaks of every assessed model; fixed during one Ipopt run). At the solution t = max_k L_k: the
/// epigraph form turns the non-smooth minimax into a smooth program whose active constraints are
/// the equal-ripple peaks of the error. Outer loop (assess, re-optimise once if the samples
/// missed a peak, grow by a point at the peak frequency, budgets) as in point_search.hpp.
///
/// Gradient method. dL_k/dx_i by finite differences of the levels in x (decades of f), one
/// reduction + evaluate_on per perturbed coordinate:
///   central (default): (L(x + h e_i) - L(x - h e_i)) / 2h, 2p reductions per Jacobian;
///   forward:           (L(x + h e_i) - L(x)) / h,           p reductions per Jacobian.
/// A step that would leave the band (or whose evaluation fails) is replaced by the one-sided
/// difference on the other side. Default h = 1e-5 decades (a relative change of 2.3e-5 in f).
/// Why: L varies in x on the scale of a resonance half-width, about zeta / ln 10 decades
/// (4e-4 decades for a damping ratio zeta = 1e-3); the central difference's truncation error is
/// then ~ (h / 4e-4)^2 / 6 ~ 1e-4 relative, while the rounding error of eps (relative 1e-12 from
/// the reduction and the dense reduced solves, i.e. 4e-13 absolute in L) divided by 2h is
/// ~ 2e-8: the step sits where truncation dominates but is still small. The forward difference
/// has a truncation error ~ h / 4e-4 (2.5e-2 at the default) and is meant for cheap, rough
/// gradients. The column of t is -1 (exact). The Hessian of the Lagrangian is Ipopt's
/// limited-memory quasi-Newton approximation (hessian_approximation = limited-memory), so no
/// second derivatives are formed.
/// Start. A gradient method finds the minimax point of the basin it starts in, and the error
/// as a function of one point's frequency has a bump per resonance: from log-spaced points Ipopt
/// alone improved a 4-point start on the test chain only from 5.5e-2 to 1.3e-2 in 40 iterations
/// (~380 evaluations), where BOBYQA's larger trust-region steps reached 3e-7 in 240. So by
/// default a short derivative-free presearch (NLopt, `presearch`, 20 p evaluations) moves the
/// points into a good basin first, and Ipopt then solves the epigraph program from its best point
/// (presearch: none starts Ipopt from the warm start directly).
/// Failures: an evaluation failure at an iterate makes eval_g return false (Ipopt then cuts the
/// step back); a failing start falls back to log-spaced points. Ipopt prints nothing (no console
/// journal, print_level 0); its return status goes into the history note of the optimum.
///
/// Parameters: MinimaxPointsOptions::specs() (keys, defaults, ranges; docs/strategies.md prints
/// them), the shared ones from PointSearchOptions.
///
/// Near-active rows (fd_rows_within, default 0.3 decades): after the first Jacobian of an Ipopt
/// run, only the rows whose level is within fd_rows_within of the largest are differenced, on
/// evaluations that solve the reduced model at those samples only; the other rows (constraints
/// with a large slack, multipliers ~ 0) keep their last values, while their exact values still
/// enter every constraint evaluation and so the line search. 4-16 % of the rows on the shipped
/// triplechain_saak09_n451 and iss minimax runs, 35-51 % with dozens of points on
/// triplechain_mess_n1501; PointObjective::jacobian.
///
/// Cost. Per Ipopt iteration: one evaluation for the constraints plus 2p (central) or p (forward)
/// for the Jacobian, plus line-search trials; each evaluation is a reduction at p points and S
/// reduced solves (the Jacobian's: the near-active samples only). An S x (p + 1) dense Jacobian
/// (S ~ a few hundred) is cheap next to that.

#include <optional>
#include <string>

#include "ecmor/strategies/strategy.hpp"
#include "optimize_points.hpp"
#include "point_objective.hpp"
#include "point_search.hpp"

namespace ecmor {

struct MinimaxPointsOptions {
  point_search::PointSearchOptions search;
  Index max_iter = 40;           ///< Ipopt iterations per optimisation
  double tol = 1e-4;             ///< Ipopt tol
  double acceptable_tol = 1e-2;  ///< Ipopt acceptable_tol
  Index max_evaluations = 0;     ///< evaluations per optimisation, 0: unlimited
  double fd_step = 1e-5;         ///< finite-difference step in decades
  bool central = true;           ///< fd_scheme: central (true) or forward
  /// Jacobian rows differenced: samples within this many decades of the largest level (0: all).
  double fd_rows_within = 0.3;
  /// NLopt algorithm of the derivative-free presearch before Ipopt; none: no presearch.
  std::optional<PointAlgorithm> presearch = PointAlgorithm::Bobyqa;
  Index presearch_evaluations = 0;  ///< its evaluations; 0: 20 p

  /// Keys, ranges and documentation of the fields above and of `search`.
  static const OptionSpecs<MinimaxPointsOptions>& specs();
  /// \throws ConfigError naming the key, its value and the rule.
  static MinimaxPointsOptions from(const ParameterMap& params) { return specs().read(params); }
};

class MinimaxPoints final : public Strategy {
 public:
  explicit MinimaxPoints(MinimaxPointsOptions options) : m_options(options) {}
  StrategyResult run(StrategyContext& context) override;
  bool moves_points() const override { return true; }

 private:
  MinimaxPointsOptions m_options;
};

/// One Ipopt run of the epigraph program from x0 on the objective's current samples (used by
/// MinimaxPoints; exposed for tests). The objective tracks the best x itself.
point_search::Optimisation minimax_optimise(const MinimaxPointsOptions& options,
                                            point_search::PointObjective& objective,
                                            const std::vector<double>& x0);

}  // namespace ecmor
