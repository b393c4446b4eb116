#include "optimize_points.hpp"

#include <algorithm>
#include <cmath>
#include <exception>
#include <nlopt.hpp>
#include <stdexcept>
#include <string>

#include "ecmor/base/error.hpp"
#include "support.hpp"

namespace ecmor {

namespace {

const char* kName = "optimize_points";

}  // namespace

std::string algorithm_name(PointAlgorithm a) {
  switch (a) {
    case PointAlgorithm::Bobyqa:
      return "bobyqa";
    case PointAlgorithm::DirectL:
      return "direct_l";
    case PointAlgorithm::DirectLThenBobyqa:
      return "direct_l_then_bobyqa";
  }
  return "unknown";
}

namespace {

// What the NLopt callback needs: the objective, the optimiser to stop when the observer asks, and
// the message of an exception the objective let through (NLopt's C++ wrapper swallows it).
struct CallbackData {
  point_search::PointObjective* objective = nullptr;
  nlopt::opt* opt = nullptr;
  std::string escaped;
};

double nlopt_objective(const std::vector<double>& x, std::vector<double>& /*grad*/, void* data) {
  auto* d = static_cast<CallbackData*>(data);
  double v = 0.0;
  try {
    v = d->objective->value(x);
  } catch (const std::exception& e) {
    // The objective absorbs ecmor::Error; anything else (a plugin's own exception type) reaches
    // NLopt, which turns it into NLOPT_FAILURE and loses the message: keep it for the status.
    d->escaped = e.what();
    throw;
  }
  if (d->objective->stopped()) d->opt->force_stop();
  return v;
}

// One NLopt run from x (in place); returns NLopt's status as text. Termination by force_stop,
// round-off, an evaluation limit or NLopt's generic failure is not the end of the search: the
// objective keeps the best point itself, and the status says what happened.
std::string run_nlopt(nlopt::algorithm algorithm, point_search::PointObjective& objective,
                      std::vector<double>& x, Index max_evaluations, double xtol_abs,
                      double initial_step) {
  const unsigned n = static_cast<unsigned>(x.size());
  nlopt::opt opt(algorithm, n);
  opt.set_lower_bounds(std::vector<double>(n, objective.lower()));
  opt.set_upper_bounds(std::vector<double>(n, objective.upper()));
  CallbackData data{&objective, &opt, {}};
  opt.set_min_objective(nlopt_objective, &data);
  opt.set_maxeval(static_cast<int>(std::max<Index>(1, max_evaluations)));
  if (xtol_abs > 0.0) opt.set_xtol_abs(xtol_abs);
  if (initial_step > 0.0) opt.set_initial_step(initial_step);
  for (double& xi : x) xi = std::clamp(xi, objective.lower(), objective.upper());
  double f = 0.0;
  try {
    const nlopt::result r = opt.optimize(x, f);
    return nlopt_result_to_string(static_cast<nlopt_result>(r));
  } catch (const nlopt::forced_stop&) {
    return "FORCED_STOP";
  } catch (const nlopt::roundoff_limited&) {
    return "ROUNDOFF_LIMITED";
  } catch (const std::invalid_argument& e) {
    throw NumericalError(std::string("strategy 'optimize_points': NLopt rejected its arguments: ") +
                         e.what());
  } catch (const std::runtime_error& e) {
    // NLOPT_FAILURE (std::runtime_error, the two above derive from it too): an internal failure
    // of the algorithm or an exception from the objective. The best x so far is still usable.
    std::string status = std::string("FAILURE (") + e.what();
    if (!data.escaped.empty()) status += ": the objective threw: " + data.escaped;
    return status + ")";
  }
}

}  // namespace

const OptionSpecs<OptimizePointsOptions>& OptimizePointsOptions::specs() {
  using O = OptimizePointsOptions;
  static const OptionSpecs<O> specs = [] {
    OptionSpecs<O> s({
        choice("algorithm", &O::algorithm,
               {{"bobyqa", PointAlgorithm::Bobyqa},
                {"direct_l", PointAlgorithm::DirectL},
                {"direct_l_then_bobyqa", PointAlgorithm::DirectLThenBobyqa}},
               "optimiser"),
        option("max_evaluations", &O::max_evaluations,
               "objective evaluations per optimisation, warm start included; 0 = 60 p")
            .range(Range::closed(0, 1e8)),
        // Both phases need evaluations: a fraction of 0 or 1 would silently drop one of them.
        option("global_fraction", &O::global_fraction,
               "DIRECT-L's share of the evaluations in direct_l_then_bobyqa")
            .range(Range::open(0, 1)),
        // DIRECT divides the p-dimensional box one coordinate at a time: with 60 p evaluations it
        // cannot resolve more than a few dimensions and only spends the budget far from the warm
        // start (measured on triplechain_mess_n1501: the error rose when a point was added at
        // p >= 7).
        option("global_max_points", &O::global_max_points,
               "direct_l_then_bobyqa runs DIRECT-L only while p <= this; above, BOBYQA alone")
            .range(Range::at_least(1)),
        // Given to NLopt as xtol_abs: x_i = log10 f_i may be 0, so NLopt's own xtol_rel,
        // relative to |x_i|, has no meaning here.
        option("xtol_rel", &O::xtol_rel,
               "BOBYQA step tolerance, relative to the band width in decades")
            .range(Range::open(0, 1)),
        option("initial_step", &O::initial_step,
               "BOBYQA's first trust-region radius; 0 = width / (4 p), a quarter of the "
               "log-spaced cell")
            .unit("decades")
            .range(Range::at_least(0).finite()),
    });
    s.include(&O::search, point_search::PointSearchOptions::specs());
    return s;
  }();
  return specs;
}

point_search::Optimisation nlopt_optimise(const OptimizePointsOptions& o,
                                          point_search::PointObjective& objective,
                                          const std::vector<double>& x0) {
  const Index p = static_cast<Index>(x0.size());
  const double width = objective.upper() - objective.lower();
  const Index budget = o.evaluations_for(p);
  const double xtol_abs = o.xtol_rel * width;
  const double step =
      o.initial_step > 0.0 ? o.initial_step : width / (4.0 * static_cast<double>(p));
  point_search::Optimisation out;
  std::vector<double> x = x0;
  // The warm start is evaluated first: DIRECT-L never samples it, and it is the reference the
  // optimum is compared with (objective_start).
  const Index before = objective.round_evaluations();
  objective.value(x);
  auto used = [&] { return objective.round_evaluations() - before; };
  const bool local_only =
      o.algorithm == PointAlgorithm::Bobyqa ||
      (o.algorithm == PointAlgorithm::DirectLThenBobyqa && p > o.global_max_points);
  if (local_only) {
    out.status = "bobyqa: " + run_nlopt(nlopt::LN_BOBYQA, objective, x, budget - 1, xtol_abs, step);
  } else if (o.algorithm == PointAlgorithm::DirectL) {
    out.status = "direct_l: " + run_nlopt(nlopt::GN_DIRECT_L, objective, x, budget - 1, 0.0, 0.0);
  } else {
    const Index global = std::max<Index>(
        1, static_cast<Index>(std::lround(o.global_fraction * static_cast<double>(budget - 1))));
    out.status = "direct_l: " + run_nlopt(nlopt::GN_DIRECT_L, objective, x, global, 0.0, 0.0);
    out.diagnostics["global_evaluations"] = static_cast<double>(used());
    const Index left = budget - used();
    if (!objective.stopped() && left > 0 && !objective.best_x().empty()) {
      // Local phase from the best point seen so far (DIRECT-L's or the warm start).
      x = objective.best_x();
      out.status += "; bobyqa: " + run_nlopt(nlopt::LN_BOBYQA, objective, x, left, xtol_abs, step);
    }
  }
  return out;
}

StrategyResult OptimizePoints::run(StrategyContext& ctx) {
  strategy_support::require_point_reducer(ctx, kName);
  const OptimizePointsOptions o = m_options;
  return point_search::run_point_search(
      ctx, o.search, kName,
      [o](point_search::PointObjective& objective, const std::vector<double>& x0) {
        return nlopt_optimise(o, objective, x0);
      });
}

}  // namespace ecmor
