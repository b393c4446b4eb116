// driver.cpp: one run, from the configuration to summary.json, in the order it happens:
// members.cpp runs the members (each strategy's records go through history.cpp), compression.cpp
// shrinks each accepted model, portfolio.cpp chooses the reported one, acceptance.cpp checks it,
// summary.cpp writes the summary.
#include "ecmor/run/driver.hpp"

#include <fmt/format.h>
#include <sys/resource.h>

#include <chrono>
#include <iomanip>
#include <memory>
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
#include "ecmor/run/history.hpp"
#include "members.hpp"
#include "portfolio.hpp"
#include "stop_policy.hpp"

namespace ecmor {

double peak_memory_mb() {
  struct rusage usage {};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

namespace {

using run::seconds_since;

/// band_error.csv: the verified error curve, for plots and for users who want to look.
void write_band_error_csv(const std::filesystem::path& path, const BandError& e) {
  write_file_atomically(path, [&](std::ostream& os) {
    // exact: 1 where the full model was solved, 0 where its response is the estimator's
    // reference model's (estimate mode).
    os << "f_hz,relative_spectral,relative_frobenius,absolute_spectral,reference_spectral,exact\n";
    os << std::setprecision(10);
    for (std::size_t k = 0; k < e.f_hz.size(); ++k) {
      os << e.f_hz[k] << ',' << e.relative_spectral[k] << ',' << e.relative_frobenius[k] << ','
         << e.absolute[k] << ',' << e.reference[k] << ','
         << (k < e.exact.size() ? static_cast<int>(e.exact[k]) : 1) << '\n';
    }
  });
}

/// The summary's facts known before anything runs: the configuration and the model.
RunSummary describe_run(const RunConfig& config, const Model& model, double load_seconds) {
  RunSummary s;
  s.config = config.source;
  s.model = config.model;
  s.model_kind = kind_of(model);
  s.full_order = size_of(model);
  s.inputs = inputs_of(model);
  s.outputs = outputs_of(model);
  s.band = config.band;
  s.tolerance = config.tolerance;
  s.norm = config.norm;
  s.verify_factor = config.verify_factor;
  s.backend = config.solver.backend;
  s.ranks = process_count();
  s.configured_reducer = config.reducer_name;
  s.configured_strategy = config.strategy_name;
  s.reducer = config.reducer_name;
  s.strategy = config.strategy_name;
  s.portfolio = !config.portfolio.empty();
  s.portfolio_prune = config.portfolio_prune;
  s.portfolio_race = config.portfolio_race;
  s.compress = config.compress;
  s.output_dir = config.output_dir;
  s.load_seconds = load_seconds;
  return s;
}

/// The totals of the run's work, at its end.
void add_totals(const run::MemberRuns& runs, const RecentFactorizations& solver,
                const ResponseCache& cache, const BandErrorEstimator& estimator,
                std::chrono::steady_clock::time_point start, RunSummary& s) {
  s.solver = solver.backend();
  s.counters = solver.counters();
  s.reducer_seconds = runs.reducer_seconds;
  s.reducer_calls = runs.reducer_calls;
  s.reducer_counters = runs.reducer_counters;
  s.reducer_reused_factorizations = runs.reducer_reuses;
  s.full_response_seconds = cache.seconds();
  s.band_error_seconds = estimator.seconds();
  s.reference_seconds = estimator.reference_seconds();
  s.full_evaluations = cache.size();
  s.seconds = seconds_since(start);
  s.peak_memory_mb = peak_memory_mb();
  s.threads = thread_budget();
}

/// What the compression of the members needs besides the members.
struct CompressionEnvironment {
  const RunConfig& config;
  BandErrorEstimator& estimator;
  const ResponseCache& cache;
  const RigidBodyModes& rigid;
  const RecentFactorizations& solver;
  RunHistory& history;
  std::chrono::steady_clock::time_point start;
};

/// Compresses member k's accepted model (compress_accepted) and records it as its own phase of
/// the history: the order before and after, the error it cost.
CompressionReport compress_member(std::size_t k, run::MemberRuns& runs, bool portfolio,
                                  const CompressionEnvironment& env) {
  StrategyResult& member = runs.results[k];
  CompressionReport compression;
  compression.error_before = member.best_error.sup_relative;
  BandError check;
  if (auto smaller =
          run::compress_accepted(*member.best, env.estimator, env.cache, env.config.tolerance,
                                 env.config.verify_factor, env.rigid, compression, check)) {
    member.best = std::move(smaller);
    member.best_error = std::move(check);
    member.best_checked = true;
    member.message += "; compressed " + compression.note;
    PortfolioAttempt& attempt = runs.attempts[k];
    attempt.order = member.best->V.cols();
    attempt.band_error = member.best_error.sup_relative;
    attempt.message = member.message;
  }
  IterationRecord r;
  r.phase = "compress";
  r.order = member.best->V.cols();
  r.points = member.best->points;
  r.band_error = member.best_error.sup_relative;
  r.f_peak_hz = member.best_error.f_peak_hz;
  r.meets_tolerance = true;
  r.seconds = seconds_since(env.start);
  r.step_seconds = compression.seconds;
  r.counters = env.solver.counters();
  r.full_evaluations = env.cache.size();
  r.sampling = member.best_error.sampling();
  r.note = (portfolio ? "[" + runs.attempts[k].label() + "] " : std::string()) + compression.note;
  r.diagnostics["order_before"] = static_cast<double>(compression.order_before);
  r.diagnostics["error_before"] = compression.error_before;
  r.diagnostics["compression_factorizations"] = static_cast<double>(compression.factorizations);
  if (portfolio) r.diagnostics["portfolio_member"] = static_cast<double>(k + 1);
  env.history.append(r);
  return compression;
}

/// Everything the run builds before its members run, in the order it is built.
struct RunSetup {
  std::unique_ptr<ShiftedSolver> backend;
  /// Shared by the error control and the reducers: the most recent factorisation serves the
  /// reducer when it asks for P(s) where the error control has just solved (a greedy point).
  std::unique_ptr<RecentFactorizations> solver;
  std::unique_ptr<ResponseCache> cache;
  std::unique_ptr<BandErrorEstimator> estimator;
};

/// The solver, the full-response cache and the estimator, which samples the full model before any
/// reduction (dense mode: its whole grid; estimate mode: the reference model's seeds).
/// \throws Interrupted when a signal ends that first sampling.
/// \throws ResourceError when the memory plan finds no way to fit the factorisations.
void set_up_error_control(const RunConfig& config, const Model& model, RunObserver* observer,
                          run::StopPolicy& stop, RunSetup& setup, MemoryPlan& plan) {
  setup.backend = make_shifted_solver(model, config.solver);
  setup.solver = std::make_unique<RecentFactorizations>(*setup.backend, 1);
  // Before the first numeric factorisation: the factors' memory from the symbolic analysis, fitted
  // under what the process may take, or the run refused.
  plan = setup.solver->plan_memory(1);
  if (observer) observer->on_memory_plan(plan);
  if (!plan.fits()) throw ResourceError(plan.refusal());
  setup.cache = std::make_unique<ResponseCache>(model, *setup.solver, config.threads);
  if (observer)
    setup.cache->set_progress([observer](const SweepProgress& p) { observer->on_sweep(p); });
  BandErrorOptions error_options = config.error;
  error_options.norm = config.norm;
  InterruptScope interrupt([&] { return stop.signalled(); });
  setup.estimator = std::make_unique<BandErrorEstimator>(*setup.cache, config.band, error_options);
}

/// The result of a run stopped by request while the estimator sampled the full model, before any
/// reduction: no model, the work done so far, nothing written.
RunResult stopped_while_sampling(RunSummary summary, const RunSetup& setup, const Interrupted& e,
                                 std::chrono::steady_clock::time_point start) {
  RunResult out;
  out.has_outputs = false;
  out.summary = std::move(summary);
  RunSummary& s = out.summary;
  s.termination = Termination::Interrupted;
  s.message = fmt::format(
      "stopped by request before the first reduction, while sampling the full model ({} "
      "frequencies done): {}",
      setup.cache->size(), e.what());
  s.solver = setup.solver->backend();
  s.counters = setup.solver->counters();
  s.full_evaluations = setup.cache->size();
  s.full_response_seconds = setup.cache->seconds();
  s.seconds = seconds_since(start);
  s.peak_memory_mb = peak_memory_mb();
  s.threads = thread_budget();
  return out;
}

RunResult run_loaded(const RunConfig& given, const Model& model, Registry& registry,
                     RunObserver* observer, std::chrono::steady_clock::time_point start,
                     double load_seconds) {
  RunConfig config = given;
  // solver.threads > 0 fixes the run's thread count; 0 leaves the process's budget (threads.hpp).
  const ThreadLimitScope threads(config.threads, "solver.threads");
  reset_thread_use();
  if (config.is_portfolio() && config.portfolio.empty())
    config.portfolio = run::default_portfolio(model, registry);
  if (observer) observer->on_model_loaded(config, model, load_seconds);

  // Bad configuration (of every member) is found before any heavy work.
  std::vector<run::PreparedMember> members = run::prepare_members(config, registry);
  const bool portfolio = !config.portfolio.empty();
  RunSummary summary = describe_run(config, model, load_seconds);
  run::StopPolicy stop(start, config.time_limit_s, observer);
  RunSetup setup;
  try {
    set_up_error_control(config, model, observer, stop, setup, summary.memory_plan);
  } catch (const Interrupted& e) {
    RunResult out = stopped_while_sampling(std::move(summary), setup, e, start);
    if (observer) observer->on_finished(out.summary);
    return out;
  }
  // The full model's rigid-body modes (the null space of K), before any reduction: every reduced
  // model is judged against them (a free body's reduced model keeps its poles at s = 0).
  const double rigid_start = seconds_since(start);
  const RigidBodyModes rigid = rigid_body_modes(model, *setup.solver);
  const double rigid_seconds = seconds_since(start) - rigid_start;
  // Files are written only with an output directory, and under MPI (PETSc backend), where every
  // rank runs this driver, by rank 0 alone.
  const bool writer = process_rank() == 0 && !config.output_dir.empty();
  RunHistory history(config.output_dir, writer, observer);

  run::MemberRuns runs = run::run_members(
      members, run::MemberEnvironment{config, model, *setup.solver, *setup.cache, *setup.estimator,
                                      rigid, start, stop, observer, history});
  // Each member's accepted model is compressed before the winner is chosen, so that a portfolio
  // reports the smallest model any member's compression reaches.
  std::vector<CompressionReport> compressions(runs.results.size());
  const CompressionEnvironment compress_env{config,        *setup.estimator, *setup.cache, rigid,
                                            *setup.solver, history,          start};
  for (std::size_t k = 0; k < runs.results.size() && config.compress; ++k) {
    if (runs.results[k].best && runs.results[k].termination == Termination::Converged)
      compressions[k] = compress_member(k, runs, portfolio, compress_env);
  }
  StrategyResult result = run::conclude(runs, portfolio, stop, summary.winner);
  if (summary.winner >= 0) {
    const std::size_t w = static_cast<std::size_t>(summary.winner);
    summary.compression = compressions[w];
    summary.reducer = runs.attempts[w].reducer;
    summary.strategy = runs.attempts[w].strategy;
  }
  summary.termination = result.termination;
  summary.message = result.message;
  summary.attempts = runs.attempts;

  RunResult out;
  if (result.best) {
    const ReducerResult& best = *result.best;
    // Written before the re-check: a run that dies in it still leaves its model.
    if (writer)
      write_reduction(config.output_dir, best.model, best.V, best.W, config.output_format);
    out.verified = run::check_reported_model(result, config, model, *setup.estimator, *setup.cache,
                                             rigid, summary);
    run::accept_model(result, out.verified, config.tolerance, summary);
    if (writer) write_band_error_csv(config.output_dir / "band_error.csv", out.verified);
    out.model = std::move(result.best);  // the bases are N x n: moved, not copied
  }
  run::judge_full_stability(config, model, rigid, rigid_seconds, summary);
  summary.iterations = history.size();
  add_totals(runs, *setup.solver, *setup.cache, *setup.estimator, start, summary);
  if (writer) write_text_atomically(config.output_dir / "summary.json", summary.to_json());
  out.summary = std::move(summary);
  out.history = history.release();
  if (observer) observer->on_finished(out.summary);
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
  return run_loaded(config, model, registry, observer, start, seconds_since(start)).summary;
}

void write_run_outputs(const RunResult& result, const std::filesystem::path& dir,
                       OutputFormat format) {
  if (!result.has_outputs) return;
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    throw IoError(fmt::format("cannot create the output directory {}: {}", dir.string(),
                              ec ? ec.message() : "not a directory"));
  if (result.model) {
    write_reduction(dir, result.model->model, result.model->V, result.model->W, format);
    write_band_error_csv(dir / "band_error.csv", result.verified);
  }
  if (!result.history.empty()) write_history(dir, result.history);
  write_text_atomically(dir / "summary.json", result.summary.to_json());
}

}  // namespace ecmor
