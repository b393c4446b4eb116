#include "optimize_points.hpp"

#include <nlopt.hpp>

#include <algorithm>
#include <cmath>
#include <exception>
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
    case PointAlgorithm::Bobyqa: return "bobyqa";
    case PointAlgorithm::DirectL: return "direct_l";
    case PointAlgorithm::DirectLThenBobyqa: return "direct_l_then_bobyqa";
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

OptimizePointsOptions OptimizePointsOptions::from(const ParameterMap& p) {
  OptimizePointsOptions o;
  o.search = point_search::PointSearchOptions::from(p, kName);
  const std::string a = p.get_string("algorithm", algorithm_name(o.algorithm),
                                     {"bobyqa", "direct_l", "direct_l_then_bobyqa"});
  o.algorithm = a == "bobyqa"     ? PointAlgorithm::Bobyqa
                : a == "direct_l" ? PointAlgorithm::DirectL
                                  : PointAlgorithm::DirectLThenBobyqa;
  o.max_evaluations = p.get_int("max_evaluations", o.max_evaluations, 0, 100000000);
  o.global_fraction = p.get_double("global_fraction", o.global_fraction, 0.0, 1.0);
  o.global_max_points = p.get_int("global_max_points", o.global_max_points, 1);
  o.xtol_rel = p.get_double("xtol_rel", o.xtol_rel, 0.0, 1.0);
  o.initial_step = p.get_double("initial_step", o.initial_step, 0.0);
  o.validate();
  return o;
}

void OptimizePointsOptions::validate() const {
  using strategy_support::sci;
  search.validate(kName);
  if (max_evaluations < 0) {
    throw ConfigError(std::string("strategy '") + kName + "': max_evaluations = " +
                      std::to_string(max_evaluations) + ": must be >= 0 (0: 60 per point)");
  }
  // Both phases need evaluations: a fraction of 0 or 1 would silently drop one of them.
  if (!(global_fraction > 0.0 && global_fraction < 1.0)) {
    throw ConfigError(std::string("strategy '") + kName + "': global_fraction = " +
                      sci(global_fraction) + ": must be in (0, 1) (exclusive)");
  }
  if (!(xtol_rel > 0.0 && xtol_rel < 1.0)) {
    throw ConfigError(std::string("strategy '") + kName + "': xtol_rel = " + sci(xtol_rel) +
                      ": must be in (0, 1) (exclusive)");
  }
  if (!(initial_step >= 0.0) || !std::isfinite(initial_step)) {
    throw ConfigError(std::string("strategy '") + kName + "': initial_step = " +
                      sci(initial_step) + ": must be finite and >= 0 (0: automatic)");
  }
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
  const bool local_only = o.algorithm == PointAlgorithm::Bobyqa ||
                          (o.algorithm == PointAlgorithm::DirectLThenBobyqa &&
                           p > o.global_max_points);
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
