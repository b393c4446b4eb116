#include "members.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <string_view>

#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"
#include "ecmor/linalg/parallel.hpp"
#include "timed_reducer.hpp"

namespace ecmor::run {

std::vector<PreparedMember> prepare_members(const RunConfig& config, Registry& registry) {
  std::vector<PortfolioMember> members = config.portfolio;
  const bool portfolio = !members.empty();
  if (!portfolio) {
    members.push_back(PortfolioMember{config.reducer_name, config.reducer_params,
                                      config.strategy_name, config.strategy_params});
  }
  std::vector<PreparedMember> out;
  for (std::size_t k = 0; k < members.size(); ++k) {
    PreparedMember p;
    p.member = members[k];
    p.reducer = registry.create(p.member.reducer_name, p.member.reducer_params);
    p.strategy = make_strategy(p.member.strategy_name, p.member.strategy_params);
    for (const Registry::Entry& e : registry.entries()) {
      if (e.info.name == p.member.reducer_name) p.info = e.info;
    }
    if (p.strategy->moves_points() && !p.info.uses_expansion_points) {
      const std::string where =
          portfolio ? fmt::format(" (strategy.members[{}])", k + 1) : std::string();
      throw ConfigError(config.source.string() + ": strategy '" + p.member.strategy_name +
                        "' moves expansion points, but reducer '" + p.member.reducer_name +
                        "' does not use them; use strategy grow_order with it" + where);
    }
    if (p.strategy->needs_modal_block() && !p.info.modal_block) {
      const std::string where =
          portfolio ? fmt::format(" (strategy.members[{}])", k + 1) : std::string();
      throw ConfigError(config.source.string() + ": strategy '" + p.member.strategy_name +
                        "' unites a modal block with expansion points, but reducer '" +
                        p.member.reducer_name + "' does not compute modes; use reducer modal" +
                        where);
    }
    out.push_back(std::move(p));
  }
  return out;
}

namespace {

/// The attempt of a member that did not start: a stop request came before it.
PortfolioAttempt not_run(const PortfolioMember& member, const StopPolicy& stop) {
  PortfolioAttempt attempt;
  attempt.reducer = member.reducer_name;
  attempt.strategy = member.strategy_name;
  attempt.termination = "not_run";
  attempt.message = stop.out_of_time() ? "the time limit was used up before it started"
                                       : "interrupted before it started";
  return attempt;
}

/// The attempt of a fallback member that did not run: a member before it met the target.
PortfolioAttempt not_needed(const PortfolioMember& member, Index met_order) {
  PortfolioAttempt attempt;
  attempt.reducer = member.reducer_name;
  attempt.strategy = member.strategy_name;
  attempt.termination = "not_needed";
  attempt.message = fmt::format(
      "fallback member not run: a member before it met the target at order {}", met_order);
  return attempt;
}

/// Runs the members of one run against its environment, one at a time; remembers the smallest
/// order that met the target, against which later members are pruned.
class MemberRunner {
 public:
  explicit MemberRunner(const MemberEnvironment& env)
      : m_env(env), m_portfolio(!env.config.portfolio.empty()) {}

  /// The smallest order that met the target so far (0: none).
  Index smallest_met_order() const { return m_smallest_met_order; }

  /// Runs member k of `count` and appends its attempt, result and reducer totals to `runs`.
  void run(std::size_t k, std::size_t count, PreparedMember& m, MemberRuns& runs) {
    PortfolioAttempt attempt;
    attempt.reducer = m.member.reducer_name;
    attempt.strategy = m.member.strategy_name;
    // The race: once a member has met the target, the next ones may make at most `race` times as
    // many full-model factorisations as the member ahead made (0: no limit). Counted, not timed,
    // so that a portfolio's result does not depend on the machine's load.
    const std::int64_t first = m_env.solver.counters().factorizations;
    const std::int64_t budget =
        m_portfolio && m_leader && m_env.config.portfolio_race > 0.0
            ? static_cast<std::int64_t>(std::ceil(
                  m_env.config.portfolio_race *
                  static_cast<double>(std::max<std::int64_t>(1, m_leader_factorizations))))
            : 0;
    std::function<bool()> over_budget;
    if (budget > 0) {
      over_budget = [this, first, budget] {
        return m_env.solver.counters().factorizations - first > budget;
      };
    }
    m_env.stop.begin_member(over_budget);
    if (m_env.observer && m_portfolio) {
      const std::string standing =
          m_leader ? fmt::format("; ahead: {} at order {} ({} factorisations, {:.2f} s){}",
                                 m_leader->label(), m_leader->order, m_leader_factorizations,
                                 m_leader->seconds,
                                 budget > 0 ? fmt::format(", race budget {} factorisations", budget)
                                            : std::string())
                   : std::string();
      m_env.observer->on_member_started(k, count, attempt.label() + standing);
    }
    const double member_start = elapsed();
    TimedReducer timed(*m.reducer, m_env.solver);
    bool pruned = false;
    StrategyContext ctx = context(k, m, timed, attempt.label(), pruned);
    StrategyResult result = run_strategy(k, m, timed, ctx, attempt.label(), member_start);
    if (m_env.stop.out_of_time() && result.termination == Termination::Interrupted) {
      result.message = m_env.stop.time_limit_text() + ": " + result.message;
    }
    const bool outraced = !pruned && m_env.stop.member_over_budget() && !m_env.stop.out_of_time() &&
                          !m_env.stop.user_stop();
    const std::int64_t made = m_env.solver.counters().factorizations - first;
    if (outraced) {
      // A model that met the target before the budget ran out stays in the race.
      if (result.termination == Termination::Interrupted && result.best &&
          result.best_error.within(m_env.config.tolerance)) {
        result.termination = Termination::Converged;
      }
      result.message = fmt::format(
          "race budget used up: {} full-model factorisations, more than {} x the {} of {}, which "
          "met the target at order {}: {}",
          made, m_env.config.portfolio_race, m_leader_factorizations, m_leader->label(),
          m_leader->order, result.message);
    }
    m_env.stop.begin_member({});
    attempt.termination = pruned     ? std::string("pruned")
                          : outraced ? std::string("outraced")
                                     : to_string(result.termination);
    attempt.message = pruned
                          ? fmt::format(
                                "stopped at order {} >= {}, the smallest order that met the target "
                                "so far: {}",
                                result.history.empty() ? 0 : result.history.back().order,
                                m_smallest_met_order, result.message)
                          : result.message;
    attempt.has_model = result.best.has_value();
    attempt.order = attempt.has_model ? result.best->V.cols() : 0;
    attempt.band_error = attempt.has_model ? result.best_error.sup_relative : 0.0;
    attempt.met = result.met();
    attempt.seconds = elapsed() - member_start;
    attempt.reducer_seconds = timed.seconds();
    attempt.iterations = static_cast<Index>(result.history.size());
    if (attempt.met && (m_smallest_met_order == 0 || attempt.order < m_smallest_met_order)) {
      m_smallest_met_order = attempt.order;
    }
    // The leader: the smallest order that met the target, ties to the faster member.
    // (Under MPI the first, as in select_winner: the ranks' clocks differ.)
    if (attempt.met && (!m_leader || attempt.order < m_leader->order ||
                        (attempt.order == m_leader->order && process_count() == 1 &&
                         attempt.seconds < m_leader->seconds))) {
      m_leader = attempt;
      m_leader_factorizations = made;
    }
    runs.reducer_seconds += timed.seconds();
    runs.reducer_calls += timed.calls();
    runs.reducer_counters += timed.counters();
    runs.reducer_reuses += timed.reuses();
    runs.attempts.push_back(attempt);
    runs.results.push_back(std::move(result));
  }

 private:
  double elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - m_env.start).count();
  }

  /// The context of member k; its records are numbered over all members and labelled, and a
  /// member that can no longer win sets `pruned` and is asked to stop.
  StrategyContext context(std::size_t k, PreparedMember& m, TimedReducer& timed,
                          const std::string& label, bool& pruned) {
    const MemberEnvironment& env = m_env;
    StrategyContext ctx;
    ctx.reducer = &timed;
    ctx.reducer_info = m.info;
    ctx.estimator = &env.estimator;
    ctx.tolerance = env.config.tolerance;
    ctx.full_rigid = &env.rigid;
    ctx.verify_factor = env.config.verify_factor;
    ctx.start = env.start;
    ctx.counters = [&env] { return env.solver.counters(); };
    ctx.full_evaluations = [&env] { return env.cache.size(); };
    ctx.stop_requested = [&env] { return env.stop.requested(); };
    ctx.on_iteration = [this, &env, &m, &pruned, k, label](const IterationRecord& rec) {
      IterationRecord r = rec;
      r.diagnostics["peak_memory_mb"] = peak_memory_mb();
      if (m_portfolio) {
        r.diagnostics["portfolio_member"] = static_cast<double>(k + 1);
        r.note = "[" + label + "] " + r.note;
      }
      const bool go_on = env.history.append(r);
      // A grow_order member's order only grows: once it reaches the smallest order that met the
      // target without meeting it, it cannot win.
      if (m_portfolio && env.config.portfolio_prune && m.strategy->order_only_grows() &&
          m_smallest_met_order > 0 && r.order >= m_smallest_met_order && !r.meets_tolerance) {
        pruned = true;
        return false;
      }
      if (any_process(env.stop.time_is_up() || !go_on)) return false;
      // The race budget (run()) ends the member too; requested() decides it collectively.
      return !(m_portfolio && m_leader && env.stop.requested());
    };
    return ctx;
  }

  /// Sets up the reducer and runs the strategy. A stop ends it as interrupted; in a portfolio a
  /// failure is recorded and ends only this member (a plain run's error propagates).
  StrategyResult run_strategy(std::size_t k, PreparedMember& m, TimedReducer& timed,
                              StrategyContext& ctx, const std::string& label, double member_start) {
    bool set_up = false;
    try {
      // The stop condition also reaches inside reducer calls (interrupt.hpp): a time limit or a
      // signal ends an ARPACK run, an IRKA or ADI iteration within a fraction of a second.
      InterruptScope interrupt([this] { return m_env.stop.requested(); });
      timed.setup(ReductionContext{&m_env.model, &m_env.solver, m_env.config.band});
      set_up = true;
      return m.strategy->run(ctx);
    } catch (const Interrupted& e) {
      // Stopped inside the reducer's setup (e.g. the Gramians of balanced truncation), before
      // any model, or inside a strategy that does not handle the stop itself (the bundled ones
      // do, keeping their best model): the run ends as interrupted, not as failed.
      StrategyResult result;
      result.termination = Termination::Interrupted;
      result.message = (set_up ? "stopped in strategy '" + m.member.strategy_name + "': "
                               : std::string("stopped during the reducer's setup: ")) +
                       e.what();
      return result;
    } catch (const std::exception& e) {
      if (!m_portfolio) throw;  // a plain run ends with its error
      // The next member may well do the job (e.g. balanced truncation refuses an undamped
      // model that modal reduction handles): record the failure and go on.
      record_failure(k, label, e.what(), member_start);
      StrategyResult result;
      result.termination = Termination::Failed;
      result.message = e.what();
      return result;
    }
  }

  /// A history record of phase "failed" for member k.
  void record_failure(std::size_t k, const std::string& label, const std::string& what,
                      double member_start) {
    IterationRecord r;
    r.phase = "failed";
    r.stable = false;  // no model: nothing is known stable
    r.band_error = std::numeric_limits<double>::quiet_NaN();
    r.seconds = elapsed();
    r.step_seconds = elapsed() - member_start;
    r.counters = m_env.solver.counters();
    r.full_evaluations = m_env.cache.size();
    r.note = "[" + label + "] failed: " + what;
    r.diagnostics["portfolio_member"] = static_cast<double>(k + 1);
    m_env.history.append(r);
  }

  const MemberEnvironment& m_env;
  const bool m_portfolio;
  Index m_smallest_met_order = 0;            // of the members so far; 0: none met yet
  std::optional<PortfolioAttempt> m_leader;  // the member that set the smallest met order
  std::int64_t m_leader_factorizations = 0;  // the full-model factorisations it made
};

}  // namespace

MemberRuns run_members(std::vector<PreparedMember>& members, const MemberEnvironment& env) {
  MemberRuns runs;
  MemberRunner runner(env);
  for (std::size_t k = 0; k < members.size(); ++k) {
    if (k > 0 && env.stop.requested()) {
      runs.attempts.push_back(not_run(members[k].member, env.stop));
      runs.results.emplace_back();
      continue;
    }
    if (members[k].member.fallback && runner.smallest_met_order() > 0) {
      runs.attempts.push_back(not_needed(members[k].member, runner.smallest_met_order()));
      runs.results.emplace_back();
      continue;
    }
    runner.run(k, members.size(), members[k], runs);
  }
  return runs;
}

}  // namespace ecmor::run
