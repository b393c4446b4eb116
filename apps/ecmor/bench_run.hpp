#pragma once
/// \file bench_run.hpp
/// What one run of `ecmor bench` measured: a row of every bench table and chart. The runs
/// themselves are made by bench() (commands.hpp, bench_run.cpp); bench_report.hpp writes the rows.

#include <string>

#include "ecmor/base/types.hpp"

namespace ecmor::app {

struct BenchRow {
  std::string config, model, reducer, strategy;
  Index n_full = 0;
  double tolerance = 0.0;
  std::string termination;  ///< to_string(Termination), or "error" when the run threw
  std::string message;
  bool met = false;
  Index order = 0;
  double band_error = 0.0, verified_error = 0.0, f_peak_hz = 0.0;
  bool stable = false;
  double seconds = 0.0, reducer_seconds = 0.0, full_response_seconds = 0.0;
  /// Time in the band error estimator, and of it the estimate mode's reference model
  /// (RunSummary::band_error_seconds, reference_seconds).
  double band_error_seconds = 0.0, reference_seconds = 0.0;
  /// Share of the reducer's time spent in sparse factorisations and solves.
  double reducer_sparse_share = 0.0;
  /// Seconds in sparse factorisations and solves over the whole run (summed over threads).
  double sparse_seconds = 0.0;
  Index factorizations = 0, solves = 0, reducer_factorizations = 0, reducer_solves = 0;
  Index reducer_calls = 0, iterations = 0;
  double peak_memory_mb = 0.0;
  /// H-infinity norm of the error system and its scope ("all frequencies": dense level-set
  /// method, "band": sampled supremum); see RunSummary::hinf.
  double hinf_error = 0.0;
  std::string hinf_scope;
};

}  // namespace ecmor::app
