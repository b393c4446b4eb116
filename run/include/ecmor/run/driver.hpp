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

#include "ecmor/plugin/registry.hpp"
#include "ecmor/run/config.hpp"
#include "ecmor/run/summary.hpp"
#include "ecmor/strategies/strategy.hpp"

namespace ecmor {

/// Observes a run (the application attaches the table printer and progress display here).
class RunObserver {
 public:
  virtual ~RunObserver() = default;
  virtual void on_model_loaded(const RunConfig&, const Model&, double /*seconds*/) {}
  /// The solver's memory plan, before the first numeric factorisation (also when it does not fit:
  /// the run then ends with a ResourceError naming it).
  virtual void on_memory_plan(const MemoryPlan&) {}
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

/// Everything a finished run produced, in memory: what its output files hold. A run without an
/// output directory (RunConfig::output_dir empty: the Python module's runs) writes nothing and
/// keeps all of it here; write_run_outputs() writes it later, file for file as a run with an
/// output directory does.
struct RunResult {
  RunSummary summary;                    ///< summary.json is summary.to_json()
  std::vector<IterationRecord> history;  ///< every record, as history.csv and history.jsonl
  /// The reported model with its bases V, W and expansion points (absent: no usable model).
  std::optional<ReducerResult> model;
  BandError verified;  ///< the reported model's re-check, as band_error.csv (with a model)
  /// False for a run stopped while it first sampled the full model, before any reduction: it has
  /// no model and no history, and write_run_outputs() writes nothing for it.
  bool has_outputs = true;
};

/// Writes a finished run's outputs into `dir` (created if needed), each file atomically: the
/// reduced model and V, W in `format` (with a model), history.csv, history.jsonl,
/// band_error.csv (with a model) and summary.json (result.summary.to_json()). Nothing for a run
/// without outputs (RunResult::has_outputs).
/// \throws IoError naming the file that could not be written.
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
