// portfolio.cpp: the names strategy.name takes, which bundled reducers a portfolio without members
// runs, and which member's model a run reports.
#include "portfolio.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <string_view>

#include "ecmor/base/error.hpp"
#include "ecmor/linalg/parallel.hpp"

namespace ecmor {

std::vector<std::string> run_strategy_names() {
  std::vector<std::string> names = strategy_names();
  names.push_back("portfolio");
  return names;
}

std::vector<ParameterDoc> run_strategy_options(const std::string& name) {
  return name == "portfolio" ? portfolio_options() : strategy_parameters(name);
}

namespace run {

std::vector<PortfolioMember> default_portfolio(const Model& model, const Registry& registry) {
  const bool second_order = kind_of(model) == ModelKind::SecondOrder;
  auto symmetric = [](const SparseMatrix& A) { return relative_asymmetry(A) <= 1e-14; };
  bool modal_suits = second_order;
  if (const auto* d = std::get_if<DescriptorModel>(&model))
    modal_suits = symmetric(d->E) && symmetric(d->A);
  struct Candidate {
    const char* reducer;
    const char* strategy;
    bool suits;
    bool fallback;
  };
  // The last member runs only when the others missed the target: mixed_basis is the slower
  // method (not pruned, its order is not monotone), and the one that reduces models the others
  // cannot (beam: krylov stagnates at order 4, balanced stops at 24, mixed_basis meets 1e-2 at
  // 104; docs/strategies.md). Its general Petrov-Galerkin path takes unsymmetric descriptors too.
  const Candidate candidates[] = {{"krylov", "greedy_points", true, false},
                                  {"balanced", "grow_order", true, false},
                                  {"modal", "grow_order", modal_suits, false},
                                  {"modal", "mixed_basis", true, true}};
  std::vector<PortfolioMember> members;
  for (const Candidate& c : candidates) {
    const auto& entries = registry.entries();
    const auto it = std::find_if(entries.begin(), entries.end(), [&](const Registry::Entry& e) {
      return e.info.name == c.reducer;
    });
    if (it == entries.end() || !c.suits) continue;
    if (second_order ? !it->info.second_order : !it->info.descriptor) continue;
    if (std::string_view(c.strategy) == "mixed_basis" && !it->info.modal_block) continue;
    PortfolioMember m;
    m.reducer_name = c.reducer;
    m.reducer_params = ParameterMap(std::string("reducer '") + c.reducer + "'");
    m.strategy_name = c.strategy;
    m.strategy_params = ParameterMap(std::string("strategy '") + c.strategy + "'");
    m.fallback = c.fallback;
    if (m.strategy_name == "greedy_points") m.strategy_params.set("moments", 2LL);
    members.push_back(std::move(m));
  }
  if (members.empty()) {
    throw ConfigError(
        "strategy 'portfolio' without members: none of the bundled reducers krylov, balanced, "
        "modal is loaded for this model; give strategy.members");
  }
  return members;
}

namespace {

/// Index of the reported attempt: the smallest order meeting the target (ties: less time), else
/// the smallest band error among members with a model; -1 when no member has one.
int select_winner(const std::vector<PortfolioAttempt>& attempts) {
  int best = -1;
  for (std::size_t k = 0; k < attempts.size(); ++k) {
    const PortfolioAttempt& a = attempts[k];
    if (!a.has_model) continue;
    if (best < 0) {
      best = static_cast<int>(k);
      continue;
    }
    const PortfolioAttempt& b = attempts[static_cast<std::size_t>(best)];
    // Ties on the order go to the faster member; under MPI to the first one, since the ranks'
    // clocks differ and every rank must report the same winner.
    const bool faster = process_count() == 1 && a.seconds < b.seconds;
    const bool better = a.met != b.met ? a.met
                        : a.met        ? (a.order != b.order ? a.order < b.order : faster)
                                       : a.band_error < b.band_error;
    if (better) best = static_cast<int>(k);
  }
  return best;
}

}  // namespace

StrategyResult conclude(MemberRuns& runs, bool portfolio, const StopPolicy& stop, int& winner) {
  std::vector<PortfolioAttempt>& attempts = runs.attempts;
  std::vector<StrategyResult>& results = runs.results;
  winner = select_winner(attempts);
  StrategyResult result;
  if (winner >= 0) {
    attempts[static_cast<std::size_t>(winner)].selected = true;
    result = std::move(results[static_cast<std::size_t>(winner)]);
  } else {
    // No model at all: the first failure (plain run: the only attempt) says why.
    result = results.empty() ? StrategyResult{} : std::move(results.front());
  }
  if (portfolio) {
    std::size_t met = 0;
    std::vector<std::string> failures;
    for (const PortfolioAttempt& a : attempts) {
      met += a.met ? 1 : 0;
      if (a.termination == "failed") failures.push_back(a.label() + ": " + a.message);
    }
    if (winner >= 0) {
      const PortfolioAttempt& w = attempts[static_cast<std::size_t>(winner)];
      result.message = fmt::format("portfolio: {} of {} members met the target; {} reported: {}",
                                   met, attempts.size(), w.label(), result.message);
    } else {
      result.termination = Termination::Failed;
      result.message =
          fmt::format("portfolio: no member produced a model ({})", fmt::join(failures, "; "));
    }
    // A stop request ends the whole run as interrupted, even when a member already met the
    // target: the members after it did not run, so "smallest" is not established.
    if ((stop.user_stop() || stop.out_of_time()) && winner >= 0) {
      for (const PortfolioAttempt& a : attempts) {
        if (a.termination == "not_run" || a.termination == "interrupted") {
          result.termination = Termination::Interrupted;
          result.message =
              (stop.out_of_time() ? stop.time_limit_text() + "; " : std::string("interrupted; ")) +
              result.message;
          break;
        }
      }
    }
  }

  return result;
}

}  // namespace run
}  // namespace ecmor
