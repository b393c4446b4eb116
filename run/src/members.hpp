#pragma once
// members.hpp: the members of a run (a plain run is a portfolio of one), created before any heavy
// work and run one after another against one solver, cache and estimator. The choice among them
// is the portfolio's (portfolio.hpp).
#include <chrono>
#include <cstdint>
#include <memory>
#include <vector>

#include "ecmor/linalg/recent_factorizations.hpp"
#include "ecmor/linalg/rigid_body.hpp"
#include "ecmor/measures/band_error.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/run/driver.hpp"
#include "ecmor/run/history.hpp"
#include "stop_policy.hpp"

namespace ecmor::run {

/// A member ready to run: created (and its parameters validated) before any heavy work.
struct PreparedMember {
  PortfolioMember member;
  std::shared_ptr<Reducer> reducer;
  std::unique_ptr<Strategy> strategy;
  ReducerInfo info;
};

/// The members of `config` (its reducer and strategy when it has no portfolio), created.
/// \throws ConfigError for bad parameters of any member, or a strategy that moves expansion
///         points with a reducer that does not use them.
std::vector<PreparedMember> prepare_members(const RunConfig& config, Registry& registry);

/// What every member runs against.
struct MemberEnvironment {
  const RunConfig& config;
  const Model& model;
  RecentFactorizations& solver;
  ResponseCache& cache;
  BandErrorEstimator& estimator;
  const RigidBodyModes& rigid;
  std::chrono::steady_clock::time_point start;
  StopPolicy& stop;
  RunObserver* observer;
  RunHistory& history;  ///< every member's records go here
};

/// One attempt and one result per member, and the reducers' totals over all members.
struct MemberRuns {
  std::vector<PortfolioAttempt> attempts;
  std::vector<StrategyResult> results;
  double reducer_seconds = 0.0;
  Index reducer_calls = 0;
  SolverCounters reducer_counters;
  std::int64_t reducer_reuses = 0;
};

/// Runs the members one after another. A plain run's error propagates; a portfolio member's
/// failure is recorded and the next member runs. A grow_order-like member (order_only_grows) is
/// pruned once its order reaches the smallest that met the target without meeting it.
MemberRuns run_members(std::vector<PreparedMember>& members, const MemberEnvironment& env);

}  // namespace ecmor::run
