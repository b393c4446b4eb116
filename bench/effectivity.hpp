#pragma once
/// \file effectivity.hpp
/// Effectivity of the estimate mode of the band error (band_error.hpp, reference_model.hpp): how
/// the estimated error curve of a reduced model compares with the true one, measured by the dense
/// mode (a full-model solve per sample). Used by bench/bench_effectivity.cpp (the table in
/// docs/error-measures.md) and by tests/integration/test_estimate_effectivity.cpp.
///
/// For one reduced model Hr of a full model H over a band, with eps(f) = ||H - Hr|| / ||H|| in the
/// options' norm:
///  1. estimate mode, on its own ResponseCache: a fresh BandErrorEstimator (ErrorVerify::Estimate),
///     offered the reduced model's V (and W when it differs); evaluate() gives the estimated curve
///     eps_est(f_k) on its samples f_k, its supremum and its peak (after its probe solves);
///  2. dense mode, on a separate ResponseCache: verify(reduced, verify_factor) gives the dense
///     supremum and where it is; evaluate_on(reduced, f_k) the true eps(f_k) at the estimate's own
///     samples. The truth is the larger of the two suprema (the estimate's samples include the
///     reduced model's pole frequencies, which the dense re-check grid may straddle);
///  3. estimate mode again: the estimate at the true peak frequency (no full solve there unless
///     one was already made), then verify(reduced, verify_factor): the certified value (the
///     largest true error over every frequency the estimate mode solved).

#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/measures/band_error.hpp"
#include "ecmor/model/model.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/run/config.hpp"

namespace ecmor::bench {

/// One reduced model's measurement (NaN: not available).
struct EffectivityReport {
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::string name;      ///< config file or family/candidate label
  Index full_order = 0;  ///< N
  Index order = 0;       ///< of the reduced model
  /// Estimate mode, evaluate(): sup of the estimated curve (probe solves included) and its peak.
  double estimate_sup = kNaN;
  double estimate_f_peak_hz = kNaN;
  /// The truth: max(dense verify(factor) sup, max_k eps(f_k)), and where it peaks.
  double true_sup = kNaN;
  double true_f_peak_hz = kNaN;
  double dense_verify_sup = kNaN;  ///< the dense verify(factor) supremum alone
  double dense_verify_f_peak_hz = kNaN;
  /// eps_est / eps over the estimate's samples without a full solve (exact == 0) where eps is
  /// finite and > 0: count, min, median, max.
  Index effectivity_count = 0;
  double effectivity_min = kNaN, effectivity_median = kNaN, effectivity_max = kNaN;
  /// The same restricted to samples where eps >= true_sup / 10 (the part of the curve that
  /// decides the supremum).
  Index near_peak_count = 0;
  double near_peak_min = kNaN, near_peak_max = kNaN;
  /// The estimate at exactly true_f_peak_hz (before the estimate mode's verify()).
  double estimate_at_true_peak = kNaN;
  /// |estimate_f_peak - true_f_peak| <= 1 % of true_f_peak.
  bool peak_frequency_located = false;
  /// estimate_at_true_peak within a factor 2 of true_sup (either way).
  bool peak_value_located = false;
  /// Estimate mode, verify(factor): the certified value and where it peaks.
  double certified = kNaN;
  double certified_f_peak_hz = kNaN;
  /// Full-model factorisations: estimate mode through evaluate() (seeds + probes) and through
  /// verify() as well; dense mode for its grid and verify(factor) (its evaluate_on at the
  /// estimate's samples, a measurement aid, is not counted).
  Index estimate_solves = 0;
  Index estimate_solves_with_verify = 0;
  Index dense_solves = 0;
  Index reference_order = 0;        ///< of the estimate mode's reference model after evaluate()
  double estimate_seconds = 0.0;    ///< wall time of the estimate mode (evaluate + verify)
  double dense_seconds = 0.0;       ///< wall time of the dense mode (grid + verify)
  double reduction_seconds = kNaN;  ///< wall time of the reduction (driver runs), else NaN

  /// estimate_sup / true_sup and certified / true_sup (NaN if true_sup is 0).
  double estimate_ratio() const;
  double certified_ratio() const;
  /// "freq", "value", "both" or "no".
  std::string peak_located() const;
};

/// Measures one reduced model as in the file comment. `options` are the error options (norm,
/// grid, ...); their `verify` field is overridden per mode. V and W may be empty (no basis
/// offered) and are ignored when they do not have N rows.
EffectivityReport measure_effectivity(const Model& model, const Band& band,
                                      BandErrorOptions options, const ReducedModel& reduced,
                                      const Matrix& V, const Matrix& W,
                                      const SolverOptions& solver = {}, int threads = 0,
                                      Index verify_factor = 4);

/// What a driver run leaves behind: the reported reduced model and its bases.
struct DriverRun {
  ReducedModel reduced;
  Matrix V, W;
  double seconds = 0.0;  ///< wall time of run_reduction
  std::string termination;
  double verified_band_error = 0.0;  ///< as the driver reported it
};

/// Runs `config` through the driver (run_reduction) into `output_dir` (config.output_dir is
/// replaced) with `registry`, then reads back the reduced model and V, W.
/// \throws std::runtime_error when the run writes no model; whatever the driver throws.
DriverRun reduce_with_driver(RunConfig config, Registry& registry,
                             const std::filesystem::path& output_dir);

/// Loads into `registry` every plugin of the default directories, of `extra_dirs` and of the
/// config's own `plugins:` list (errors of the default directories are ignored).
void load_plugins_for(Registry& registry, const RunConfig& config,
                      const std::vector<std::filesystem::path>& extra_dirs);

/// The Markdown table of the reports (header and one row each).
std::string effectivity_table(const std::vector<EffectivityReport>& reports);
/// One row of that table.
std::string effectivity_row(const EffectivityReport& r);

}  // namespace ecmor::bench
