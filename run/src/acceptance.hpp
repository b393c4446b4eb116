#pragma once
// acceptance.hpp: the checks of the reported model, whichever strategy chose it: re-checked on an
// independent grid (dense) or against full solves where the estimate peaks (estimate mode), its
// H-infinity error and its stability judged against the full model's; then the decision. The
// summary is filled from these checks, never from the strategy's own numbers alone.
#include <chrono>

#include "ecmor/linalg/rigid_body.hpp"
#include "ecmor/measures/band_error.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/run/config.hpp"
#include "ecmor/run/summary.hpp"

namespace ecmor::run {

/// Seconds since `start`.
double seconds_since(std::chrono::steady_clock::time_point start);

/// The checks of result.best into `summary` (the model fields: order, errors, H-infinity, error
/// control, stability against `rigid`, points). The re-check is estimator.verify, or the
/// compression's own when result.best_checked. Returns it (band_error.csv). Decides nothing and
/// writes nothing.
BandError check_reported_model(const StrategyResult& result, const RunConfig& config,
                               const Model& model, BandErrorEstimator& estimator,
                               const ResponseCache& cache, const RigidBodyModes& rigid,
                               RunSummary& summary);

/// The decision: a converged result whose re-check `verified` misses `tolerance` ends as failed.
void accept_model(const StrategyResult& result, const BandError& verified, double tolerance,
                  RunSummary& summary);

/// The full model's own stability into `summary` (full_stability, its seconds, how its rigid-body
/// modes were found), and a warning when it is unstable or marginal (not for a free body whose
/// reduced model keeps its rigid-body modes).
void judge_full_stability(const RunConfig& config, const Model& model, const RigidBodyModes& rigid,
                          double rigid_seconds, RunSummary& summary);

}  // namespace ecmor::run
