// The portfolio strategy: several reducer/strategy pairs raced on one model.
//
// The reference for "smallest model meeting the target" is each member run on its own (a plain
// run through the same driver); the portfolio must report the smallest of their orders, and its
// model must meet the target on the driver's independent re-check. Failing members must not stop
// the others; every attempt must be in summary.json and the history.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/run/config.hpp"
#include "ecmor/run/driver.hpp"

namespace fs = std::filesystem;

namespace ecmor {
namespace {

// iss_so (N = 270), a band with 43 modes: modal, second-order BT and greedy Krylov all meet 1e-2,
// at different orders, in a few seconds each.
const std::string kHead = R"(
model:  {dir: models/iss_so}
band:   {f_min_hz: 0.0159, f_max_hz: 2.0}
target: {tolerance: 1.0e-2, norm: spectral}
)";
const std::string kModal = "    - reducer: {name: modal}\n";
const std::string kBalanced =
    "    - reducer: {name: balanced, structure: second_order, variant: pv}\n";
const std::string kKrylov =
    "    - reducer: {name: krylov}\n      strategy: {name: greedy_points, moments: 2}\n";

void fill_registry(Registry& registry) {
  for (const char* lib : {"libecmor_modal.so", "libecmor_balanced.so", "libecmor_krylov.so"}) {
    registry.load_plugin(fs::path(ECMOR_TEST_PLUGIN_DIR) / lib);
  }
  // A reducer that fails in setup, as a real one does on a model it cannot handle.
  ReducerFactory failing;
  failing.info.name = "test_fails_in_setup";
  failing.info.description = "throws NumericalError from setup()";
  failing.info.second_order = true;
  failing.info.descriptor = true;
  failing.create = [](const ParameterMap&) -> std::unique_ptr<Reducer> {
    struct Failing final : Reducer {
      void setup(const ReductionContext&) override {
        throw NumericalError("test_fails_in_setup: factorisation failed at shift 0");
      }
      ReducerResult reduce(const ReductionRequest&) override { return {}; }
      Index max_order() const override { return 0; }
    };
    return std::make_unique<Failing>();
  };
  registry.add(std::move(failing));
}

std::string portfolio_yaml(const std::string& members, const fs::path& out,
                           const std::string& extra = "") {
  // Without the compression after acceptance: these tests are about the members' own orders
  // (pruning compares the accepted ones, docs/strategies.md).
  return kHead + "strategy:\n  name: portfolio\n" + extra + "  members:\n" + members +
         "output: {dir: " + out.string() + "}\ncompress: false\n";
}

RunSummary run_yaml(const std::string& yaml, Registry& registry, RunObserver* observer = nullptr) {
  return run_reduction(parse_run_config(yaml, "portfolio.yaml"), registry, observer);
}

nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

void expect_config_error(const std::string& yaml, const std::vector<std::string>& parts) {
  try {
    parse_run_config(yaml, "portfolio.yaml");
    ADD_FAILURE() << "no ConfigError for:\n" << yaml;
  } catch (const ConfigError& e) {
    for (const std::string& p : parts)
      EXPECT_NE(std::string(e.what()).find(p), std::string::npos)
          << "'" << p << "' not in: " << e.what();
  }
}

TEST(PortfolioConfig, ParsesMembersWithTheirParameters) {
  const RunConfig c = parse_run_config(
      portfolio_yaml(kModal + kKrylov, "out/x", "  prune: false\n"), "portfolio.yaml");
  EXPECT_EQ(c.reducer_name, "portfolio");
  EXPECT_EQ(c.strategy_name, "portfolio");
  EXPECT_FALSE(c.portfolio_prune);
  ASSERT_EQ(c.portfolio.size(), 2u);
  EXPECT_EQ(c.portfolio[0].label(), "modal/grow_order");
  EXPECT_EQ(c.portfolio[1].label(), "krylov/greedy_points");
  EXPECT_EQ(c.portfolio[1].strategy_params.get_int("moments", 0), 2);
}

TEST(PortfolioConfig, BadShapesAreErrorsWithTheirLine) {
  expect_config_error(kHead + "reducer: {name: modal}\nstrategy:\n  name: portfolio\n  members:\n" +
                          kModal + "output: {dir: o}\n",
                      {"portfolio.yaml:5", "remove the top-level 'reducer' section"});
  expect_config_error(kHead + "strategy: {name: portfolio, members: modal}\noutput: {dir: o}\n",
                      {"strategy.members must be a list", "found a scalar"});
  expect_config_error(kHead + "strategy: {name: portfolio, members: []}\noutput: {dir: o}\n",
                      {"found an empty list"});
  expect_config_error(portfolio_yaml("    - strategy: {name: grow_order}\n", "o"),
                      {"missing required key 'strategy.members[1].reducer'"});
  expect_config_error(
      portfolio_yaml(kModal + "    - reducer: {name: modal}\n      strategy: "
                              "{name: portfolio}\n",
                     "o"),
      {"portfolio.yaml:10", "strategy.members[2].strategy", "cannot be a portfolio"});
  expect_config_error(
      portfolio_yaml("    - reducer: {name: modal}\n      strategy: {time_limit_s: 5}\n", "o"),
      {"strategy.members[1].strategy.time_limit_s", "give it as strategy.time_limit_s"});
  expect_config_error(portfolio_yaml("    - reducer: {name: modal}\n      strategi: {}\n", "o"),
                      {"unknown key 'strategi'", "did you mean 'strategy'"});
  expect_config_error(portfolio_yaml(kModal, "o", "  prune: maybe\n"),
                      {"portfolio.yaml:7: strategy.prune = 'maybe': must be true or false"});
  expect_config_error(portfolio_yaml(kModal, "o", "  tolerance: 3\n"), {"unknown key 'tolerance'"});
}

TEST(Portfolio, MemberParameterErrorsAreFoundBeforeAnyRun) {
  test::TempDir dir;
  Registry registry;
  fill_registry(registry);
  try {
    run_yaml(portfolio_yaml(kModal + "    - reducer: {name: krylov, pionts: 3}\n", dir / "out"),
             registry);
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("strategy.members[2]"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("pionts"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "out" / "history.csv")) << "work started before the check";
}

// Each member alone, then all of them raced: the portfolio reports the smallest order any of them
// reaches, with the target met on the independent re-check, and computes fewer full-model
// responses than the separate runs together (they share the response cache).
TEST(Portfolio, ReportsTheSmallestModelOfItsMembersAndSharesTheFullResponses) {
  test::TempDir dir;
  Registry registry;
  fill_registry(registry);
  Index smallest = 0;
  Index separate_evaluations = 0;
  std::string smallest_label;
  for (const auto& [member, label] :
       {std::pair{kModal, "modal/grow_order"}, std::pair{kBalanced, "balanced/grow_order"},
        std::pair{kKrylov, "krylov/greedy_points"}}) {
    const RunSummary alone = run_yaml(portfolio_yaml(member, dir / label), registry);
    ASSERT_EQ(alone.termination, Termination::Converged) << label << ": " << alone.message;
    separate_evaluations += alone.full_evaluations;
    if (smallest == 0 || alone.order < smallest) {
      smallest = alone.order;
      smallest_label = label;
    }
  }
  const RunSummary s = run_yaml(
      portfolio_yaml(kModal + kBalanced + kKrylov, dir / "all", "  prune: false\n"), registry);
  ASSERT_EQ(s.termination, Termination::Converged) << s.message;
  EXPECT_EQ(s.order, smallest);
  EXPECT_EQ(s.reducer + "/" + s.strategy, smallest_label);
  EXPECT_LE(s.verified_band_error, 1e-2);
  EXPECT_LT(s.full_evaluations, separate_evaluations);
  ASSERT_EQ(s.attempts.size(), 3u);
  int selected = 0;
  for (const PortfolioAttempt& a : s.attempts) {
    EXPECT_TRUE(a.met) << a.label() << ": " << a.message;
    EXPECT_GE(a.order, s.order) << a.label();
    selected += a.selected ? 1 : 0;
  }
  EXPECT_EQ(selected, 1);

  const nlohmann::json j = read_json(dir / "all" / "summary.json");
  EXPECT_EQ(j["reducer"], "portfolio");
  EXPECT_EQ(j["portfolio"]["winner"], smallest_label);
  ASSERT_EQ(j["portfolio"]["members"].size(), 3u);
  EXPECT_EQ(j["final_order"], smallest);
}

// Without members, the bundled reducers that suit the model: all three for a second-order model,
// no modal truncation for an unsymmetric descriptor model (cdplayer), and modal / mixed_basis last
// as the fallback, not run here because an earlier member met the target. Each member's result is
// checked against the same member run alone; the portfolio reports the smallest passing order.
TEST(Portfolio, WithoutMembersTriesTheBundledReducersThatSuitTheModel) {
  struct Case {
    const char* model;
    std::vector<std::string> labels;
  };
  const Case cases[] = {
      {"build_so",
       {"krylov/greedy_points", "balanced/grow_order", "modal/grow_order", "modal/mixed_basis"}},
      {"cdplayer", {"krylov/greedy_points", "balanced/grow_order", "modal/mixed_basis"}}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.model);
    test::TempDir dir;
    Registry registry;
    fill_registry(registry);
    const std::string head = std::string("model: {dir: models/") + c.model +
                             "}\nband: {f_min_hz: 0.1, f_max_hz: 100}\n"
                             "target: {tolerance: 1.0e-2}\n";
    const RunSummary s = run_yaml(head + "strategy: {name: portfolio, prune: false}\n" +
                                      "output: {dir: " + (dir / "all").string() + "}\n",
                                  registry);
    ASSERT_EQ(s.attempts.size(), c.labels.size()) << s.message;
    Index smallest = 0;
    for (std::size_t k = 0; k < c.labels.size(); ++k) {
      const PortfolioAttempt& a = s.attempts[k];
      EXPECT_EQ(a.label(), c.labels[k]);
      if (k + 1 == c.labels.size()) {
        EXPECT_EQ(a.termination, "not_needed") << a.message;
        EXPECT_FALSE(a.has_model);
        continue;
      }
      // The member alone, as a plain run, ends the same way.
      const std::string reducer = c.labels[k].substr(0, c.labels[k].find('/'));
      const std::string strategy = c.labels[k].substr(c.labels[k].find('/') + 1);
      const RunSummary alone =
          run_yaml(head + "reducer: {name: " + reducer + "}\nstrategy: {name: " + strategy +
                       (strategy == "greedy_points" ? ", moments: 2" : "") +
                       "}\noutput: {dir: " + (dir / reducer).string() + "}\n",
                   registry);
      EXPECT_EQ(a.met, alone.exit_code() == 0) << a.label() << ": " << a.message;
      if (a.met) {
        EXPECT_EQ(a.order, alone.order) << a.label();
        if (smallest == 0 || a.order < smallest) smallest = a.order;
      }
    }
    ASSERT_GT(smallest, 0) << "no member met the target: " << s.message;
    ASSERT_EQ(s.termination, Termination::Converged) << s.message;
    EXPECT_EQ(s.order, smallest);
    EXPECT_LE(s.verified_band_error, 1e-2);
  }
}

// A fallback member runs only when no member before it met the target: after a member that
// misses (krylov capped at order 4) it runs and its model is reported; after one that meets the
// target it is "not_needed", without a model, in the attempts and in summary.json.
TEST(Portfolio, AFallbackMemberRunsOnlyWhenNoMemberBeforeItMetTheTarget) {
  test::TempDir dir;
  Registry registry;
  fill_registry(registry);
  const std::string misses =
      "    - reducer: {name: krylov}\n      strategy: {name: grow_order, max_order: 4}\n";
  const std::string modal_fallback = "    - reducer: {name: modal}\n      fallback: true\n";
  const RunSummary rescued = run_yaml(portfolio_yaml(misses + modal_fallback, dir / "a"), registry);
  ASSERT_EQ(rescued.attempts.size(), 2u);
  EXPECT_FALSE(rescued.attempts[0].met) << rescued.attempts[0].message;
  EXPECT_TRUE(rescued.attempts[1].met) << rescued.attempts[1].message;
  EXPECT_EQ(rescued.termination, Termination::Converged) << rescued.message;
  EXPECT_EQ(rescued.reducer, "modal");
  EXPECT_LE(rescued.verified_band_error, 1e-2);

  const std::string balanced_fallback = kBalanced + "      fallback: true\n";
  const RunSummary s = run_yaml(portfolio_yaml(kModal + balanced_fallback, dir / "b"), registry);
  ASSERT_EQ(s.attempts.size(), 2u);
  EXPECT_TRUE(s.attempts[0].met) << s.attempts[0].message;
  EXPECT_EQ(s.attempts[1].termination, "not_needed");
  EXPECT_FALSE(s.attempts[1].has_model);
  EXPECT_NE(s.attempts[1].message.find("met the target at order " + std::to_string(s.order)),
            std::string::npos)
      << s.attempts[1].message;
  EXPECT_EQ(s.reducer, "modal");
  const nlohmann::json j = read_json(dir / "b" / "summary.json");
  EXPECT_EQ(j["portfolio"]["members"][1]["termination"], "not_needed");

  expect_config_error(
      portfolio_yaml(kModal + "      fallback: maybe\n", "o"),
      {"portfolio.yaml:9", "strategy.members[1].fallback must be true or false", "'maybe'"});
}

TEST(Portfolio, WithoutMembersAndWithoutTheBundledReducersIsNamed) {
  test::TempDir dir;
  Registry registry;  // no plugin loaded
  const std::string msg = test::message_of<ConfigError>([&] {
    run_yaml(kHead + "strategy: {name: portfolio}\noutput: {dir: " + dir.path().string() + "}\n",
             registry);
  });
  EXPECT_NE(msg.find("none of the bundled reducers krylov, balanced, modal is loaded"),
            std::string::npos)
      << msg;
}

// Pruning: with the best member first, a later grow_order member stops as soon as its order
// reaches the winner's without meeting the target, and the result is the same as without pruning.
TEST(Portfolio, PruningStopsMembersThatCannotWinWithoutChangingTheResult) {
  test::TempDir dir;
  Registry registry;
  fill_registry(registry);
  const RunSummary pruned = run_yaml(portfolio_yaml(kBalanced + kModal, dir / "p"), registry);
  const RunSummary full =
      run_yaml(portfolio_yaml(kBalanced + kModal, dir / "f", "  prune: false\n"), registry);
  ASSERT_EQ(pruned.termination, Termination::Converged) << pruned.message;
  EXPECT_EQ(pruned.order, full.order);
  EXPECT_EQ(pruned.reducer, full.reducer);
  ASSERT_EQ(pruned.attempts.size(), 2u);
  EXPECT_EQ(pruned.attempts[1].termination, "pruned") << pruned.attempts[1].message;
  EXPECT_EQ(full.attempts[1].termination, "converged");
  EXPECT_LT(pruned.attempts[1].iterations, full.attempts[1].iterations);
}

// The race: once a member has met the target, a later one may make at most `race` times as many
// full-model factorisations as the member ahead. Counted, not timed: the same stops on any
// machine. With race 0.01 (a budget of one factorisation after krylov's) modal is stopped as
// "outraced" with the budget named, and the portfolio reports krylov's model; without the race
// (0) modal runs to its own end.
TEST(Portfolio, TheRaceStopsALaterMemberAtItsFactorisationBudget) {
  test::TempDir dir;
  Registry registry;
  fill_registry(registry);
  const RunSummary raced =
      run_yaml(portfolio_yaml(kKrylov + kModal, dir / "r", "  race: 0.01\n"), registry);
  const RunSummary free =
      run_yaml(portfolio_yaml(kKrylov + kModal, dir / "f", "  race: 0\n"), registry);
  ASSERT_EQ(raced.termination, Termination::Converged) << raced.message;
  ASSERT_EQ(raced.attempts.size(), 2u);
  EXPECT_TRUE(raced.attempts[0].met);
  EXPECT_EQ(raced.attempts[1].termination, "outraced") << raced.attempts[1].message;
  EXPECT_NE(raced.attempts[1].message.find("race budget used up"), std::string::npos)
      << raced.attempts[1].message;
  EXPECT_NE(raced.attempts[1].message.find("krylov/greedy_points"), std::string::npos);
  EXPECT_EQ(raced.reducer, "krylov");
  ASSERT_EQ(free.attempts.size(), 2u);
  EXPECT_EQ(free.attempts[1].termination, "converged") << free.attempts[1].message;
  EXPECT_LT(raced.attempts[1].iterations, free.attempts[1].iterations);
  EXPECT_LT(raced.counters.factorizations, free.counters.factorizations);
  const nlohmann::json j = read_json(dir / "r" / "summary.json");
  EXPECT_EQ(j["portfolio"]["race"], 0.01);
  EXPECT_EQ(j["portfolio"]["members"][1]["termination"], "outraced");
  expect_config_error(portfolio_yaml(kModal, "o", "  race: -1\n"), {"race", "-1"});
}

TEST(Portfolio, AFailingMemberIsRecordedAndTheNextOneRuns) {
  test::TempDir dir;
  Registry registry;
  fill_registry(registry);
  const RunSummary s =
      run_yaml(portfolio_yaml("    - reducer: {name: test_fails_in_setup}\n" + kModal, dir / "out"),
               registry);
  ASSERT_EQ(s.termination, Termination::Converged) << s.message;
  EXPECT_EQ(s.reducer, "modal");
  ASSERT_EQ(s.attempts.size(), 2u);
  EXPECT_EQ(s.attempts[0].termination, "failed");
  EXPECT_NE(s.attempts[0].message.find("factorisation failed at shift 0"), std::string::npos);
  EXPECT_FALSE(s.attempts[0].has_model);
  // The history has the failure as a record of its own, before the modal records.
  std::ifstream in(dir / "out" / "history.jsonl");
  std::string first;
  std::getline(in, first);
  const nlohmann::json rec = nlohmann::json::parse(first);
  EXPECT_EQ(rec["phase"], "failed");
  EXPECT_NE(rec["note"].get<std::string>().find("test_fails_in_setup"), std::string::npos);
  // No model, so nothing is known stable (the row once said stable = true) or within tolerance.
  EXPECT_EQ(rec["stable"], false);
  EXPECT_EQ(rec["meets_tolerance"], false);
  EXPECT_EQ(rec["order"], 0);
}

TEST(Portfolio, NoMemberWithAModelIsAFailedRunNamingEveryFailure) {
  test::TempDir dir;
  Registry registry;
  fill_registry(registry);
  const RunSummary s = run_yaml(portfolio_yaml("    - reducer: {name: test_fails_in_setup}\n"
                                               "    - reducer: {name: test_fails_in_setup}\n",
                                               dir / "out"),
                                registry);
  EXPECT_EQ(s.termination, Termination::Failed);
  EXPECT_FALSE(s.has_model);
  EXPECT_EQ(s.exit_code(), 1);
  EXPECT_NE(s.message.find("no member produced a model"), std::string::npos) << s.message;
  EXPECT_FALSE(fs::exists(dir / "out" / "V.mtx"));
  EXPECT_TRUE(fs::exists(dir / "out" / "summary.json"));
}

// A stop request (Ctrl-C) during the first member ends the portfolio: the others are "not_run",
// the run is interrupted and keeps its best model.
TEST(Portfolio, AStopRequestEndsTheWholePortfolio) {
  struct StopAfterFirstRecords final : RunObserver {
    int records = 0;
    bool on_iteration(const IterationRecord&) override { return ++records < 3; }
    bool stop_requested() override { return records >= 3; }
  } observer;
  test::TempDir dir;
  Registry registry;
  fill_registry(registry);
  const RunSummary s =
      run_yaml(portfolio_yaml(kModal + kBalanced, dir / "out"), registry, &observer);
  EXPECT_EQ(s.termination, Termination::Interrupted) << s.message;
  ASSERT_EQ(s.attempts.size(), 2u);
  EXPECT_EQ(s.attempts[0].termination, "interrupted");
  EXPECT_EQ(s.attempts[1].termination, "not_run");
  EXPECT_TRUE(s.has_model);
  EXPECT_EQ(s.exit_code(), 2);
}

// The reducer's setup() is the reducer's work: low-rank ADI factorises there, and reduce() then
// only projects. Those factorisations (and their time) count as the reducer's, not as error
// control.
TEST(Driver, ReducerSetupWorkCountsAsTheReducers) {
  test::TempDir dir;
  Registry registry;
  fill_registry(registry);
  const RunSummary s = run_yaml(kHead +
                                    "reducer:  {name: balanced, structure: second_order, variant: "
                                    "pv, gramians: lowrank}\n"
                                    "strategy: {name: grow_order, max_order: 20}\n"
                                    "output: {dir: " +
                                    (dir / "out").string() + "}\n",
                                registry);
  ASSERT_TRUE(s.has_model) << s.message;
  // ADI: at least one factorisation per shift, all of them in setup().
  EXPECT_GT(s.reducer_counters.factorizations, 0);
  EXPECT_GT(s.reducer_seconds, 0.0);
  // The rest are the error control's: at least one per full-model response.
  EXPECT_LE(s.reducer_counters.factorizations, s.counters.factorizations);
  EXPECT_GE(s.counters.factorizations - s.reducer_counters.factorizations, s.full_evaluations);
}

}  // namespace
}  // namespace ecmor
