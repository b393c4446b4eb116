#pragma once
// portfolio.hpp: the members of a portfolio without `members`, and the choice of the reported
// member once all have run (members.hpp runs them).
#include <vector>

#include "ecmor/plugin/registry.hpp"
#include "ecmor/run/config.hpp"
#include "members.hpp"
#include "stop_policy.hpp"

namespace ecmor::run {

/// The members of `strategy: {name: portfolio}` without `members`: the bundled reducers loaded in
/// `registry` that suit the model, in this order: krylov / greedy_points (2 moments, any model),
/// balanced / grow_order (any model; it refuses an unstable one by name), modal / grow_order
/// (second-order models, and descriptor models with symmetric E and A), and last modal /
/// mixed_basis as a fallback member (any model; run only when none of the others met the
/// target). Point strategies first: they are never pruned, and the order they reach prunes the
/// grow_order members after them.
/// \throws ConfigError when none of them is loaded.
std::vector<PortfolioMember> default_portfolio(const Model& model, const Registry& registry);

/// The run's result: the winner's (smallest order meeting the target, ties to the faster; else
/// the smallest band error), with the portfolio's message; `winner` is its index, -1 for none.
StrategyResult conclude(MemberRuns& runs, bool portfolio, const StopPolicy& stop, int& winner);

}  // namespace ecmor::run
