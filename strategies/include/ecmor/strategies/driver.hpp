#pragma once
/// \file driver.hpp
/// One configured reduction run, end to end: load the model, build the shifted solver and the
/// full-response cache, create the reducer and the strategy, run, re-check the result on an
/// independent grid, and write every output atomically into the output directory:
///   Mr.mtx Dr.mtx Kr.mtx Br.mtx Cr.mtx [Cvr.mtx]  or  Er.mtx Ar.mtx Br.mtx Cr.mtx
///   V.mtx W.mtx history.csv history.jsonl band_error.csv summary.json
/// The history is written after every iteration, so an interrupted run keeps it.

#include <filesystem>
#include <string>

#include "ecmor/config.hpp"
#include "ecmor/registry.hpp"
#include "ecmor/strategies/strategy.hpp"

namespace ecmor {

/// What a run reports (also written as summary.json).
struct RunSummary {
  Termination termination = Termination::Failed;
  std::string message;
  Index full_order = 0;          ///< N of the full model
  bool has_model = false;        ///< a reduced model was written
  Index order = 0;
  double band_error = 0.0;       ///< sup relative band error of the reported model
  double f_peak_hz = 0.0;
  double verified_band_error = 0.0;  ///< on the independent denser grid
  double verified_f_peak_hz = 0.0;
  double hinf_absolute = 0.0;    ///< band H-infinity of the error (verify grid)
  double h2_absolute = 0.0;      ///< band H2 of the error (verify grid)
  bool stable = false;
  double tolerance = 0.0;
  double seconds = 0.0;
  double load_seconds = 0.0;
  /// Time inside the reducer's reduce() calls (the reduction proper), how many calls, and the
  /// solver work done inside them (the unavoidable sparse part of the reduction).
  double reducer_seconds = 0.0;
  Index reducer_calls = 0;
  SolverCounters reducer_counters;
  /// Time spent computing full-model responses for the error estimates.
  double full_response_seconds = 0.0;
  SolverCounters counters;
  Index full_evaluations = 0;
  double peak_memory_mb = 0.0;
  Index iterations = 0;
  std::filesystem::path output_dir;

  /// 0: target met; 2: usable model, target not met; 1: no usable model.
  int exit_code() const;
};

/// Observes a run (the application attaches the table printer and progress display here).
class RunObserver {
 public:
  virtual ~RunObserver() = default;
  virtual void on_model_loaded(const RunConfig&, const Model&, double /*seconds*/) {}
  /// Return false to stop the run (it then ends as Interrupted and still writes its outputs).
  virtual bool on_iteration(const IterationRecord&) { return true; }
  /// Polled often during a run (between records too); return true to stop it as Interrupted.
  virtual bool stop_requested() { return false; }
  virtual void on_finished(const RunSummary&) {}
};

/// Runs one configured reduction. Errors in the input (model files, configuration, plugin
/// parameters) throw; everything after the reducer is set up ends in a RunSummary.
RunSummary run_reduction(const RunConfig& config, Registry& registry, RunObserver* observer = nullptr);

/// Peak resident memory of this process in MiB (getrusage).
double peak_memory_mb();

}  // namespace ecmor
