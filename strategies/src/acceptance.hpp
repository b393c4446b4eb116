#pragma once
// acceptance.hpp: the checks of the reported model, whichever strategy chose it: written, then
// re-checked on an independent grid (dense) or against full solves where the estimate peaks
// (estimate mode), its H-infinity error and its stability judged against the full model's. The
// summary is filled from these checks, never from the strategy's own numbers alone.
#include <chrono>
#include <nlohmann/json.hpp>

#include "ecmor/linalg/rigid_body.hpp"
#include "ecmor/measures/band_error.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/strategies/driver.hpp"

namespace ecmor::driver {

/// Seconds since `start`.
double seconds_since(std::chrono::steady_clock::time_point start);

/// For result.best: re-checks it (estimator.verify) into `verified`, computes the H-infinity
/// error and the stability against `rigid`; fills the model fields of `summary` (a converged
/// result that fails the re-check becomes failed) and returns the JSON of the checks:
/// hinf_error, undefined_frequencies_hz, sampling, error_control, points. Writes nothing.
nlohmann::json accept_model(const StrategyResult& result, const RunConfig& config,
                            const Model& model, BandErrorEstimator& estimator,
                            const ResponseCache& cache, const RigidBodyModes& rigid,
                            std::chrono::steady_clock::time_point start, RunSummary& summary,
                            BandError& verified);

/// band_error.csv: the verified error curve, for plots and for users who want to look.
void write_band_error_csv(const std::filesystem::path& path, const BandError& e);

/// The full model's own stability (summary.full_stability), a warning when it is unstable or
/// marginal (not for a free body whose reduced model keeps its rigid-body modes), and the JSON
/// full_model_stability and, with a model, stability.
nlohmann::json report_stability(const RunConfig& config, const Model& model,
                                const RigidBodyModes& rigid, double rigid_seconds,
                                std::chrono::steady_clock::time_point start, RunSummary& summary);

/// summary.json's remaining fields: the run's identity, result, model, backend, portfolio,
/// times and counters.
nlohmann::json summary_json(const RunSummary& summary, const RunConfig& config, const Model& model,
                            const std::string& solver_backend, int winner);

}  // namespace ecmor::driver
