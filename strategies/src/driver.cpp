#include "ecmor/strategies/driver.hpp"

#include <fmt/format.h>
#include <sys/resource.h>

#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "acceptance.hpp"
#include "compression.hpp"
#include "ecmor/base/atomic_file.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/interrupt.hpp"
#include "ecmor/base/threads.hpp"
#include "ecmor/linalg/parallel.hpp"
#include "ecmor/linalg/recent_factorizations.hpp"
#include "ecmor/model/model_io.hpp"
#include "portfolio.hpp"
#include "stop_policy.hpp"

namespace ecmor {

int RunSummary::exit_code() const {
  if (termination == Termination::Converged) return 0;
  return has_model ? 2 : 1;
}

double peak_memory_mb() {
  struct rusage usage {};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

namespace {

/// The summary of a run stopped by request while the estimator sampled the full model, before
/// any reduction: no model, the work done so far.
RunSummary stopped_while_sampling(const RunConfig& config, const Model& model,
                                  const RecentFactorizations& solver, const ResponseCache& cache,
                                  const Interrupted& e, double load_seconds,
                                  std::chrono::steady_clock::time_point start) {
  RunSummary summary;
  summary.termination = Termination::Interrupted;
  summary.message = fmt::format(
      "stopped by request before the first reduction, while sampling the full model ({} "
      "frequencies done): {}",
      cache.size(), e.what());
  summary.tolerance = config.tolerance;
  summary.output_dir = config.output_dir;
  summary.reducer = config.reducer_name;
  summary.strategy = config.strategy_name;
  summary.full_order = size_of(model);
  summary.counters = solver.counters();
  summary.full_evaluations = cache.size();
  summary.full_response_seconds = cache.seconds();
  summary.load_seconds = load_seconds;
  summary.seconds = driver::seconds_since(start);
  summary.peak_memory_mb = peak_memory_mb();
  return summary;
}

}  // namespace

namespace {

RunResult run_loaded(const RunConfig& given, const Model& model, Registry& registry,
                     RunObserver* observer, std::chrono::steady_clock::time_point start,
                     double load_seconds) {
  using driver::seconds_since;
  RunConfig config = given;
  // solver.threads > 0 fixes the run's thread count; 0 leaves the process's budget (threads.hpp).
  const ThreadLimitScope threads(config.threads, "solver.threads");
  reset_thread_use();
  if (config.is_portfolio() && config.portfolio.empty())
    config.portfolio = default_portfolio(model, registry);
  if (observer) observer->on_model_loaded(config, model, load_seconds);

  // Bad configuration (of every member) is found before any heavy work.
  std::vector<driver::PreparedMember> members = driver::prepare_members(config, registry);
  const bool portfolio = !config.portfolio.empty();

  std::unique_ptr<ShiftedSolver> backend = make_shifted_solver(model, config.solver);
  // Shared by the error control and the reducers: the most recent factorisation serves the
  // reducer when it asks for P(s) where the error control has just solved (a greedy point).
  const auto solver = std::make_unique<RecentFactorizations>(*backend, 1);
  ResponseCache cache(model, *solver, config.threads);
  if (observer) cache.set_progress([observer](const SweepProgress& p) { observer->on_sweep(p); });
  BandErrorOptions error_options = config.error;
  error_options.norm = config.norm;
  driver::StopPolicy stop(start, config.time_limit_s, observer);

  // The estimator samples the full model before any reduction (dense mode: its whole grid;
  // estimate mode: the reference model's seeds): a signal ends that sweep too.
  std::unique_ptr<BandErrorEstimator> estimator;
  try {
    InterruptScope interrupt([&] { return stop.signalled(); });
    estimator = std::make_unique<BandErrorEstimator>(cache, config.band, error_options);
  } catch (const Interrupted& e) {
    RunResult out;
    out.summary = stopped_while_sampling(config, model, *solver, cache, e, load_seconds, start);
    if (observer) observer->on_finished(out.summary);
    return out;
  }
  // The full model's rigid-body modes (the null space of K), before any reduction: every reduced
  // model is judged against them (a free body's reduced model keeps its poles at s = 0).
  const double rigid_start = seconds_since(start);
  const RigidBodyModes rigid = rigid_body_modes(model, *solver);
  const double rigid_seconds = seconds_since(start) - rigid_start;
  // Files are written only with an output directory, and under MPI (PETSc backend), where every
  // rank runs this driver, by rank 0 alone.
  const bool writer = process_rank() == 0 && !config.output_dir.empty();
  // Created at the first record: a reducer that refuses the model in setup() leaves no output
  // directory behind (bad input is reported before anything is written).
  std::optional<HistoryWriter> history;
  RunResult out;
  auto record = [&](const IterationRecord& r) {
    // A write error is rank 0's alone; made collective, so that every rank leaves the strategy
    // at the same record instead of the others waiting in the next collective solve.
    std::string failure;
    if (writer) {
      try {
        if (!history) history.emplace(config.output_dir);
        history->append(r);
      } catch (const Error& e) {
        failure = e.what();
      }
    }
    out.history.push_back(r);
    if (any_process(!failure.empty()))
      throw IoError(failure.empty() ? std::string("rank 0 could not write the history") : failure);
  };

  driver::MemberRuns runs = driver::run_members(
      members, driver::MemberEnvironment{config, model, *solver, cache, *estimator, rigid, start,
                                         stop, observer, record,
                                         [&] { return static_cast<Index>(out.history.size()); }});
  // Each member's accepted model is compressed before the winner is chosen, so that a portfolio
  // reports the smallest model any member's compression reaches.
  std::vector<CompressionReport> compressions(runs.results.size());
  if (config.compress) {
    for (std::size_t k = 0; k < runs.results.size(); ++k) {
      StrategyResult& member = runs.results[k];
      if (!member.best || member.termination != Termination::Converged) continue;
      CompressionReport& compression = compressions[k];
      compression.error_before = member.best_error.sup_relative;
      BandError check;
      if (auto smaller =
              driver::compress_accepted(*member.best, *estimator, cache, config.tolerance,
                                        config.verify_factor, rigid, compression, check)) {
        member.best = std::move(smaller);
        member.best_error = std::move(check);
        member.best_checked = true;
        member.message += "; compressed " + compression.note;
        PortfolioAttempt& attempt = runs.attempts[k];
        attempt.order = member.best->V.cols();
        attempt.band_error = member.best_error.sup_relative;
        attempt.message = member.message;
      }
      // Its own phase in the history: the order before and after, the error it cost.
      IterationRecord r;
      r.iteration = static_cast<Index>(out.history.size()) + 1;
      r.phase = "compress";
      r.order = member.best->V.cols();
      r.points = member.best->points;
      r.band_error = member.best_error.sup_relative;
      r.f_peak_hz = member.best_error.f_peak_hz;
      r.meets_tolerance = true;
      r.seconds = driver::seconds_since(start);
      r.step_seconds = compression.seconds;
      r.counters = solver->counters();
      r.full_evaluations = cache.size();
      r.sampling = member.best_error.sampling();
      r.note =
          (portfolio ? "[" + runs.attempts[k].label() + "] " : std::string()) + compression.note;
      r.diagnostics["order_before"] = static_cast<double>(compression.order_before);
      r.diagnostics["error_before"] = compression.error_before;
      r.diagnostics["compression_factorizations"] = static_cast<double>(compression.factorizations);
      if (portfolio) r.diagnostics["portfolio_member"] = static_cast<double>(k + 1);
      record(r);
      if (observer) observer->on_iteration(r);
    }
  }
  int winner = -1;
  StrategyResult result = driver::conclude(runs, portfolio, stop, winner);
  const CompressionReport compression =
      winner >= 0 ? compressions[static_cast<std::size_t>(winner)] : CompressionReport{};

  RunSummary& summary = out.summary;
  summary.termination = result.termination;
  summary.message = result.message;
  summary.tolerance = config.tolerance;
  summary.output_dir = config.output_dir;
  summary.iterations = static_cast<Index>(out.history.size());
  summary.attempts = runs.attempts;
  summary.compression = compression;
  const bool won = winner >= 0;
  summary.reducer =
      won ? runs.attempts[static_cast<std::size_t>(winner)].reducer : config.reducer_name;
  summary.strategy =
      won ? runs.attempts[static_cast<std::size_t>(winner)].strategy : config.strategy_name;
  summary.load_seconds = load_seconds;
  summary.full_order = size_of(model);

  nlohmann::json j;
  if (result.best) {
    const ReducerResult& best = *result.best;
    // Written before the re-check: a run that dies in it still leaves its model.
    if (writer)
      write_reduction(config.output_dir, best.model, best.V, best.W, config.output_format);
    j.update(driver::accept_model(result, config, model, *estimator, cache, rigid, start, summary,
                                  out.verified));
    if (writer) driver::write_band_error_csv(config.output_dir / "band_error.csv", out.verified);
    out.model = std::move(result.best);  // the bases are N x n: moved, not copied
  }
  j.update(driver::report_stability(config, model, rigid, rigid_seconds, start, summary));
  summary.counters = solver->counters();
  summary.reducer_seconds = runs.reducer_seconds;
  summary.reducer_calls = runs.reducer_calls;
  summary.reducer_counters = runs.reducer_counters;
  summary.reducer_reused_factorizations = runs.reducer_reuses;
  summary.full_response_seconds = cache.seconds();
  summary.band_error_seconds = estimator->seconds();
  summary.reference_seconds = estimator->reference_seconds();
  summary.full_evaluations = cache.size();
  summary.seconds = seconds_since(start);
  summary.peak_memory_mb = peak_memory_mb();
  summary.threads = thread_budget();
  j.update(driver::summary_json(summary, config, model, solver->backend(), winner));
  out.summary_json = j.dump(2) + "\n";
  if (writer) write_text_atomically(config.output_dir / "summary.json", out.summary_json);

  if (observer) observer->on_finished(summary);
  return out;
}

}  // namespace

RunResult run_reduction(const RunConfig& config, const Model& model, Registry& registry,
                        RunObserver* observer) {
  return run_loaded(config, model, registry, observer, std::chrono::steady_clock::now(), 0.0);
}

RunSummary run_reduction(const RunConfig& config, Registry& registry, RunObserver* observer) {
  const auto start = std::chrono::steady_clock::now();
  const Model model = load_model(config.model);
  return run_loaded(config, model, registry, observer, start, driver::seconds_since(start)).summary;
}

void write_run_outputs(const RunResult& result, const std::filesystem::path& dir,
                       OutputFormat format) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    throw IoError(fmt::format("cannot create the output directory {}: {}", dir.string(),
                              ec ? ec.message() : "not a directory"));
  if (result.model) {
    write_reduction(dir, result.model->model, result.model->V, result.model->W, format);
    driver::write_band_error_csv(dir / "band_error.csv", result.verified);
  }
  if (!result.history.empty()) write_history(dir, result.history);
  if (!result.summary_json.empty())
    write_text_atomically(dir / "summary.json", result.summary_json);
}

}  // namespace ecmor
