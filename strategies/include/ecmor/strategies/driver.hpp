#pragma once
/// \file driver.hpp
/// One configured reduction run, end to end: load the model, build the shifted solver and the
/// full-response cache, create the reducer and the strategy, run, re-check the result on an
/// independent grid, and write every output atomically into the output directory:
///   Mr.mtx Dr.mtx Kr.mtx Br.mtx Cr.mtx [Cvr.mtx]  or  Er.mtx Ar.mtx Br.mtx Cr.mtx
///   V.mtx W.mtx history.csv history.jsonl band_error.csv summary.json
/// The history is written after every iteration, so an interrupted run keeps it.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "ecmor/base/threads.hpp"
#include "ecmor/measures/stability.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/strategies/config.hpp"
#include "ecmor/strategies/strategy.hpp"

namespace ecmor {

/// One member's run in a portfolio (a plain run has one attempt too).
struct PortfolioAttempt {
  std::string reducer, strategy;
  std::string termination;  ///< to_string(Termination), or "pruned", "failed", "not_run"
  std::string message;
  bool has_model = false;
  Index order = 0;          ///< of the member's best model
  double band_error = 0.0;  ///< the member's best band error (estimator grid)
  bool met = false;
  double seconds = 0.0;  ///< wall time of the member (setup and strategy)
  double reducer_seconds = 0.0;
  Index iterations = 0;
  bool selected = false;  ///< this member's model is the run's result
  std::string label() const { return reducer + "/" + strategy; }
};

/// The compression of an accepted model (YAML `compress: true`; the driver's
/// compress_accepted): what it tried, what it kept and what it cost.
struct CompressionReport {
  bool attempted = false;  ///< a converged run's model was offered to it
  bool applied = false;    ///< a smaller model replaced the accepted one
  std::string method;      ///< "reduced modal truncation [with static correction]" or "reduced
                           ///< response-weighted projection (one-sided | two-sided)"
  std::string note;        ///< what it did, or why it kept the accepted model
  Index order_before = 0, order_after = 0;
  double error_before = 0.0;  ///< the accepted model's band error, as the strategy measured it
  double error_after = 0.0;   ///< the compressed model's re-check (applied only)
  Index candidates = 0;       ///< compressed models whose error was evaluated
  Index verifications = 0;    ///< of them, re-checked against the full model
  std::int64_t factorizations = 0;  ///< full-model factorisations the compression caused
  double seconds = 0.0;
};

/// What a run reports (also written as summary.json).
struct RunSummary {
  Termination termination = Termination::Failed;
  std::string message;
  Index full_order = 0;    ///< N of the full model
  bool has_model = false;  ///< a reduced model was written
  Index order = 0;
  double band_error = 0.0;  ///< sup relative band error of the reported model
  double f_peak_hz = 0.0;
  double verified_band_error = 0.0;  ///< on the independent re-check (denser grid or full solves)
  /// How the error was established: "dense" or "estimate" (BandErrorEstimator::mode()), and on
  /// how many frequencies the reported model was compared with the full model's own H.
  std::string error_mode;
  /// error.verify auto: when and why the run left the estimate for the dense sampling (else empty).
  std::string error_mode_switch;
  Index checked_frequencies = 0;
  double verified_f_peak_hz = 0.0;
  double hinf_absolute = 0.0;  ///< band H-infinity of the error (verify grid)
  double h2_absolute = 0.0;    ///< band H2 of the error (verify grid)
  /// H-infinity norm of the error system H - Hr: over all frequencies by the level-set method
  /// when the full model is small enough to be dense (<= RunConfig::hinf_dense_states first-order
  /// stable; YAML error.hinf_dense_states), else the band supremum of the re-check grid.
  /// hinf_method says which, in words.
  double hinf_error = 0.0;
  std::string hinf_scope;  ///< "all frequencies" or "band"
  std::string hinf_method;
  /// The reported model's stability judged against the full model's (reduced_model_stability):
  /// its label says which case applies ("stable with 6 rigid-body modes like the full model").
  ReducedStability stability;
  bool stable = false;  ///< stability.accepted()
  /// The full model's own stability (stability.hpp), decided once per run: a stable reduced model
  /// of an unstable or undamped full model matches it in the band, not in the time domain.
  StabilityReport full_stability;
  /// Things a user must know that do not change the termination (written to summary.json and
  /// printed), e.g. that the full model is unstable.
  std::vector<std::string> warnings;
  double tolerance = 0.0;
  double seconds = 0.0;
  double load_seconds = 0.0;
  /// Time inside the reducer's setup() and reduce() calls (the reduction proper), how many
  /// reduce() calls, and the solver work done inside them (the unavoidable sparse part of the
  /// reduction; setup() holds, e.g., the low-rank ADI of balanced truncation).
  double reducer_seconds = 0.0;
  Index reducer_calls = 0;
  SolverCounters reducer_counters;
  /// Factorisations the reducers asked for and got from the error control's most recent full
  /// solves (RecentFactorizations): requested, not made again; not in reducer_counters.
  std::int64_t reducer_reused_factorizations = 0;
  /// Time spent computing full-model responses for the error estimates.
  double full_response_seconds = 0.0;
  /// Time inside the band error estimator (BandErrorEstimator::seconds(): judging candidates, the
  /// full responses included) and, of it, the estimate mode's reference model
  /// (BandErrorEstimator::reference_seconds()). Error control proper is full_response_seconds +
  /// reference_seconds; the rest of band_error_seconds is evaluating the candidates themselves.
  double band_error_seconds = 0.0;
  double reference_seconds = 0.0;
  SolverCounters counters;
  Index full_evaluations = 0;
  double peak_memory_mb = 0.0;
  /// The thread budget at the end of the run and the counts it chose (threads.hpp).
  ThreadBudget threads;
  Index iterations = 0;
  std::filesystem::path output_dir;
  /// Reducer and strategy that produced the reported model (a portfolio's winner; for a plain run
  /// the configured ones).
  std::string reducer, strategy;
  /// Every member of a portfolio in configuration order (one entry for a plain run).
  std::vector<PortfolioAttempt> attempts;
  CompressionReport compression;

  /// 0: target met; 2: usable model, target not met; 1: no usable model.
  int exit_code() const;
};

/// Observes a run (the application attaches the table printer and progress display here).
class RunObserver {
 public:
  virtual ~RunObserver() = default;
  virtual void on_model_loaded(const RunConfig&, const Model&, double /*seconds*/) {}
  /// Portfolio runs: member `index` (0-based) of `count` starts.
  virtual void on_member_started(std::size_t /*index*/, std::size_t /*count*/,
                                 const std::string& /*label*/) {}
  /// Return false to stop the run (it then ends as Interrupted and still writes its outputs).
  virtual bool on_iteration(const IterationRecord&) { return true; }
  /// A long sweep of full-model responses progresses (called after each round of it).
  virtual void on_sweep(const SweepProgress&) {}
  /// Polled often during a run (between records too); return true to stop it as Interrupted.
  virtual bool stop_requested() { return false; }
  virtual void on_finished(const RunSummary&) {}
};

/// The members of `strategy: {name: portfolio}` without `members`: the bundled reducers loaded in
/// `registry` that suit the model, in this order: krylov / greedy_points (2 moments, any model),
/// balanced / grow_order (any model; it refuses an unstable one by name), modal / grow_order
/// (second-order models, and descriptor models with symmetric E and A), and last modal /
/// mixed_basis as a fallback member (any model; run only when none of the others met the
/// target). Point strategies first: they are never pruned, and the order they reach prunes the
/// grow_order members after them.
/// \throws ConfigError when none of them is loaded.
std::vector<PortfolioMember> default_portfolio(const Model& model, const Registry& registry);

/// Everything a finished run produced, in memory: what its output files hold. A run without an
/// output directory (RunConfig::output_dir empty: the Python module's runs) writes nothing and
/// keeps all of it here; write_run_outputs() writes it later, file for file as a run with an
/// output directory does.
struct RunResult {
  RunSummary summary;
  std::string summary_json;              ///< the text of summary.json
  std::vector<IterationRecord> history;  ///< every record, as history.csv and history.jsonl
  /// The reported model with its bases V, W and expansion points (absent: no usable model).
  std::optional<ReducerResult> model;
  BandError verified;  ///< the reported model's re-check, as band_error.csv (with a model)
};

/// Writes a finished run's outputs into `dir` (created if needed), each file atomically: the
/// reduced model and V, W in `format` (with a model), history.csv, history.jsonl,
/// band_error.csv (with a model) and summary.json.
/// 	hrows IoError naming the file that could not be written.
void write_run_outputs(const RunResult& result, const std::filesystem::path& dir,
                       OutputFormat format);

/// Runs one configured reduction of a model already in memory (config.model is then only
/// reported, not read). With config.output_dir empty nothing is written; otherwise the outputs
/// are written as the run goes (the history after every iteration), as below.
RunResult run_reduction(const RunConfig& config, const Model& model, Registry& registry,
                        RunObserver* observer = nullptr);

/// Runs one configured reduction; a portfolio (config.is_portfolio()) runs its members one
/// after the other on the same solver and full-response cache, so full-model responses computed
/// for one member are reused by the next; it reports the smallest model that meets the target
/// (ties: the member that took less time), else the most accurate one. A member that throws is a
/// failed attempt and the next one runs; every attempt is in the history and in summary.json.
/// Errors in the input (model files, configuration, plugin
/// parameters) throw; everything after the reducer is set up ends in a RunSummary.
RunSummary run_reduction(const RunConfig& config, Registry& registry,
                         RunObserver* observer = nullptr);

/// Peak resident memory of this process in MiB (getrusage).
double peak_memory_mb();

}  // namespace ecmor
