#include "ecmor/strategies/strategy.hpp"

#include "ecmor/base/error.hpp"
#include "greedy_points.hpp"
#include "grow_order.hpp"
#include "minimax_points.hpp"
#include "mixed_basis.hpp"
#include "optimize_points.hpp"

namespace ecmor {

Strategy::~Strategy() = default;

std::string to_string(Termination t) {
  switch (t) {
    case Termination::Converged:
      return "converged";
    case Termination::MaxOrderReached:
      return "max_order_reached";
    case Termination::IterationLimit:
      return "iteration_limit";
    case Termination::ReducerExhausted:
      return "reducer_exhausted";
    case Termination::Stagnated:
      return "stagnated";
    case Termination::Interrupted:
      return "interrupted";
    case Termination::Failed:
      return "failed";
  }
  return "unknown";
}

std::vector<std::string> strategy_names() {
  return {"grow_order", "greedy_points", "optimize_points", "minimax_points", "mixed_basis"};
}

std::vector<ParameterDoc> strategy_parameters(const std::string& name) {
  if (name == "grow_order") return GrowOrderOptions::specs().docs();
  if (name == "greedy_points") return GreedyPointsOptions::specs().docs();
  if (name == "optimize_points") return OptimizePointsOptions::specs().docs();
  if (name == "minimax_points") return MinimaxPointsOptions::specs().docs();
  if (name == "mixed_basis") return MixedBasisOptions::specs().docs();
  throw ConfigError("unknown strategy '" + name + "'" + suggestion(name, strategy_names()));
}

std::unique_ptr<Strategy> make_strategy(const std::string& name, const ParameterMap& params) {
  std::unique_ptr<Strategy> s;
  if (name == "grow_order") {
    s = std::make_unique<GrowOrder>(GrowOrderOptions::from(params));
  } else if (name == "greedy_points") {
    s = std::make_unique<GreedyPoints>(GreedyPointsOptions::from(params));
  } else if (name == "optimize_points") {
    s = std::make_unique<OptimizePoints>(OptimizePointsOptions::from(params));
  } else if (name == "minimax_points") {
    s = std::make_unique<MinimaxPoints>(MinimaxPointsOptions::from(params));
  } else if (name == "mixed_basis") {
    s = std::make_unique<MixedBasis>(MixedBasisOptions::from(params));
  } else {
    throw ConfigError("unknown strategy '" + name + "'" + suggestion(name, strategy_names()));
  }
  params.check_unused();
  return s;
}

}  // namespace ecmor
