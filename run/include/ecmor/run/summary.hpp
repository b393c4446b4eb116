#pragma once
/// \file summary.hpp
/// What a run reports: every fact of summary.json in one struct, filled as the run goes (driver.cpp
/// in order: the configuration, the members, the compression, the checks of the reported model,
/// the full model's stability, the totals) and written by one function, RunSummary::to_json().

#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "ecmor/base/threads.hpp"
#include "ecmor/linalg/memory_plan.hpp"
#include "ecmor/measures/stability.hpp"
#include "ecmor/model/band.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/run/config.hpp"
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

/// The compression of an accepted model (YAML `compress: true`; compress_accepted): what it tried,
/// what it kept and what it cost.
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

/// The H-infinity norm of the error system H - Hr of the reported model, and how it was obtained:
/// over all frequencies by the dense level-set method when the full model is small enough
/// (RunConfig::hinf_dense_states), else the band supremum of the re-check grid.
struct HinfReport {
  double value = 0.0;
  double f_peak_hz = -1.0;  ///< < 0: not known
  bool certified = false;   ///< the level-set bracket converged
  std::string scope;        ///< "all frequencies" or "band"
  std::string method;       ///< in words
  double seconds = 0.0;
};

/// What the reported error rests on: every frequency where the full model was solved, and how
/// well the estimate predicted the error there (estimate mode).
struct ErrorControlReport {
  /// "dense" or "estimate" (BandErrorEstimator::mode()).
  std::string mode;
  /// error.verify auto: when and why the run left the estimate for the dense sampling (else empty).
  std::string mode_switch;
  std::string escalation;  ///< BandErrorEstimator::escalation_note()
  Index reference_order = 0;
  /// Frequencies at which the reported model was compared with the full model's own H.
  Index checked_frequencies = 0;
  /// Estimate mode: every frequency the full model was solved at (empty in dense mode).
  std::vector<double> checked_f_hz;
  /// Estimate mode: sup of the estimated error where the full model was not solved (NaN: none),
  /// the reference model's own evaluation error at its solves, and the effectivity (estimate /
  /// true) at the frequencies checked with a full solve (count 0, NaN: none).
  double estimate_sup_unchecked = std::numeric_limits<double>::quiet_NaN();
  double reference_floor = 0.0;
  Index effectivity_count = 0;
  double effectivity_min = std::numeric_limits<double>::quiet_NaN();
  double effectivity_median = std::numeric_limits<double>::quiet_NaN();
  double effectivity_max = std::numeric_limits<double>::quiet_NaN();
};

/// What a run reports (written as summary.json by to_json()).
struct RunSummary {
  // --- the run as configured ------------------------------------------------------------------
  std::filesystem::path config;  ///< the YAML file (empty for a configuration from memory)
  ModelSource model;             ///< as the configuration names it (path empty: given in memory)
  ModelKind model_kind = ModelKind::SecondOrder;
  Index full_order = 0;  ///< N of the full model
  Index inputs = 0, outputs = 0;
  Band band;
  double tolerance = 0.0;
  ErrorNorm norm = ErrorNorm::Spectral;
  Index verify_factor = 0;
  std::string backend;  ///< solver.backend as configured
  std::string solver;   ///< the shifted solver in use (ShiftedSolver::backend())
  int ranks = 1;        ///< MPI processes
  std::string configured_reducer, configured_strategy;  ///< "portfolio" for a portfolio
  bool portfolio = false;
  bool portfolio_prune = true;
  double portfolio_race = 0.0;
  bool compress = true;  ///< compression enabled
  std::filesystem::path output_dir;

  // --- the outcome ----------------------------------------------------------------------------
  Termination termination = Termination::Failed;
  std::string message;
  /// Reducer and strategy that produced the reported model (a portfolio's winner; for a plain run
  /// the configured ones).
  std::string reducer, strategy;
  /// Every member of a portfolio in configuration order (one entry for a plain run) and the index
  /// of the reported one (-1: none).
  std::vector<PortfolioAttempt> attempts;
  int winner = -1;
  CompressionReport compression;
  Index iterations = 0;

  // --- the reported model, checked (acceptance.hpp) -----------------------------------------
  bool has_model = false;  ///< a reduced model was written
  Index order = 0;
  double band_error = 0.0;  ///< sup relative band error of the reported model
  double f_peak_hz = 0.0;
  double verified_band_error = 0.0;  ///< on the independent re-check (denser grid or full solves)
  double verified_f_peak_hz = 0.0;
  double hinf_absolute = 0.0;  ///< band H-infinity of the error (verify grid)
  double h2_absolute = 0.0;    ///< band H2 of the error (verify grid)
  HinfReport hinf;
  ErrorControlReport error_control;
  std::vector<double> undefined_frequencies_hz;  ///< where the full H vanishes
  std::string estimator_sampling, verify_sampling;
  std::vector<ExpansionPoint> points;  ///< of the reported model
  /// The reported model's stability judged against the full model's (reduced_model_stability):
  /// its label says which case applies ("stable with 6 rigid-body modes like the full model").
  ReducedStability stability;
  bool stable = false;  ///< stability.accepted()

  // --- the full model ------------------------------------------------------------------------
  /// The full model's own stability (stability.hpp), decided once per run: a stable reduced model
  /// of an unstable or undamped full model matches it in the band, not in the time domain.
  StabilityReport full_stability;
  double full_stability_seconds = 0.0;
  std::string full_rigid_method;  ///< how its rigid-body modes were found (RigidBodyModes)
  double full_rigid_seconds = 0.0;
  /// Things a user must know that do not change the termination (written to summary.json and
  /// printed), e.g. that the full model is unstable.
  std::vector<std::string> warnings;

  // --- times and work -----------------------------------------------------------------------
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
  /// The solver's memory plan, made before the first numeric factorisation (memory_plan.hpp):
  /// summary.json `memory`, with the measured peak beside the predicted one.
  MemoryPlan memory_plan;
  /// The thread budget at the end of the run and the counts it chose (threads.hpp).
  ThreadBudget threads;

  /// 0: target met; 2: usable model, target not met; 1: no usable model.
  int exit_code() const;
  /// summary.json: every field above, as docs/user-guide.md lists it (2-space indented, with a
  /// final newline).
  std::string to_json() const;
};

}  // namespace ecmor
