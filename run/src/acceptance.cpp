// acceptance.cpp: the checks of the reported model and the decision (acceptance.hpp).
#include "acceptance.hpp"

#include <fmt/format.h>

#include <variant>

#include "ecmor/base/error.hpp"
#include "ecmor/measures/hinf_norm.hpp"
#include "ecmor/model/dense_model.hpp"

namespace ecmor::run {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

namespace {

// The error system's H-infinity norm, stating how it was obtained: exact (certified level-set
// bracket over all frequencies) for small full models, else the sampled band supremum.
HinfReport hinf_of_error(const Model& full, const ReducedModel& reduced, const BandError& verified,
                         Index dense_states) {
  HinfReport r;
  const auto start = std::chrono::steady_clock::now();
  const Index states =
      std::holds_alternative<SecondOrderModel>(full) ? 2 * size_of(full) : size_of(full);
  std::string why_sampled = fmt::format(
      "the full model has {} first-order states (dense "
      "level-set method up to error.hinf_dense_states = {})",
      states, dense_states);
  if (states <= dense_states) {
    try {
      const HinfResult h = hinf_error_norm(densify(full), reduced);
      r.value = h.value;
      r.f_peak_hz = h.f_peak_hz;
      r.certified = h.converged;
      r.scope = "all frequencies";
      r.method = h.method + ", dense; " + h.message;
      r.seconds = seconds_since(start);
      return r;
    } catch (const Error& e) {
      why_sampled = std::string("the dense level-set method refused: ") + e.what();
    }
  }
  r.value = verified.hinf_absolute;
  r.scope = "band";
  r.method =
      "sup of sigma_max(H - Hr) on the independent re-check grid (sampled: a lower bound "
      "of the band H-infinity norm); " +
      why_sampled;
  r.seconds = seconds_since(start);
  return r;
}

/// What the re-check rests on (summary.error_control).
ErrorControlReport error_control(const BandErrorEstimator& estimator, const ResponseCache& cache,
                                 const BandError& verified) {
  ErrorControlReport e;
  e.mode = to_string(estimator.mode());
  e.mode_switch = estimator.switch_note();
  e.escalation = estimator.escalation_note();
  e.reference_order = estimator.reference_order();
  e.checked_frequencies = verified.checked_samples;
  if (estimator.mode() == ErrorVerify::Estimate) e.checked_f_hz = cache.frequencies();
  e.estimate_sup_unchecked = verified.estimate_sup;
  e.reference_floor = verified.reference_floor;
  e.effectivity_count = verified.effectivity_count;
  e.effectivity_min = verified.effectivity_min;
  e.effectivity_median = verified.effectivity_median;
  e.effectivity_max = verified.effectivity_max;
  return e;
}

}  // namespace

BandError check_reported_model(const StrategyResult& result, const RunConfig& config,
                               const Model& model, BandErrorEstimator& estimator,
                               const ResponseCache& cache, const RigidBodyModes& rigid,
                               RunSummary& summary) {
  const ReducerResult& best = *result.best;
  // The reported model is always re-checked independently, converged or not (a stop request
  // no longer applies here: the check of the model being written is part of writing it). A
  // compressed model was re-checked by its compression, which is not repeated.
  BandError verified =
      result.best_checked ? result.best_error : estimator.verify(best.model, config.verify_factor);
  summary.has_model = true;
  summary.order = best.V.cols();
  // Estimate mode: the reported error is the re-check's, measured against the full model at
  // every frequency it solved; the strategy's value of a model that never passed is an estimate.
  const bool estimate_mode = estimator.mode() == ErrorVerify::Estimate;
  summary.band_error = estimate_mode ? verified.sup_relative : result.best_error.sup_relative;
  summary.f_peak_hz = estimate_mode ? verified.f_peak_hz : result.best_error.f_peak_hz;
  summary.verified_band_error = verified.sup_relative;
  summary.verified_f_peak_hz = verified.f_peak_hz;
  summary.hinf_absolute = verified.hinf_absolute;
  summary.h2_absolute = verified.h2_absolute;
  summary.hinf = hinf_of_error(model, best.model, verified, config.hinf_dense_states);
  summary.error_control = error_control(estimator, cache, verified);
  summary.undefined_frequencies_hz = verified.undefined_f_hz;
  summary.estimator_sampling = result.best_error.sampling();
  summary.verify_sampling = verified.sampling();
  summary.points = best.points;
  summary.stability = reduced_model_stability(best.model, rigid);
  summary.stable = summary.stability.accepted();
  return verified;
}

void accept_model(const StrategyResult& result, const BandError& verified, double tolerance,
                  RunSummary& summary) {
  if (summary.termination == Termination::Converged && !verified.within(tolerance)) {
    // Cannot happen for strategies that verify before accepting; guard the contract anyway.
    summary.termination = Termination::Failed;
    summary.message = "reported model fails the independent re-check: " + result.message;
  }
}

void judge_full_stability(const RunConfig& config, const Model& model, const RigidBodyModes& rigid,
                          double rigid_seconds, RunSummary& summary) {
  // The full model's own stability, after the reduction so that a refusal or bad configuration is
  // reported first; dense for small models, structural (K, D inertia) for large second-order ones.
  const auto start = std::chrono::steady_clock::now();
  summary.full_stability = full_model_stability(model, config.stability_dense_states, rigid);
  summary.full_stability_seconds = seconds_since(start);
  summary.full_rigid_method = rigid.describe();
  summary.full_rigid_seconds = rigid_seconds;
  const StabilityReport& fs = summary.full_stability;
  // A free body whose reduced model keeps its rigid-body modes is the expected case, not a
  // warning: both have the same poles at s = 0 and damped elastic poles.
  const bool rigid_like_full = summary.has_model &&
                               summary.stability.verdict == ReducedVerdict::RigidLikeFull &&
                               fs.verdict == Stability::Marginal && rigid.count > 0;
  if ((fs.verdict == Stability::Unstable || fs.verdict == Stability::Marginal) &&
      !rigid_like_full) {
    // The reduced model is called stable only when the rule accepts it; a model with fewer
    // rigid-body modes than the full model has undamped poles at 0 and is named as such.
    std::string reduced_note;
    if (summary.has_model && summary.stable) {
      reduced_note =
          "; the reduced model is stable, so it can represent the full model in the band only, "
          "not in the time domain";
    } else if (summary.has_model && summary.stability.verdict == ReducedVerdict::RigidSubset) {
      reduced_note = fmt::format(
          "; the reduced model keeps only {} of its {} rigid-body modes (undamped poles at s = "
          "0): it is not as stable as the full model",
          summary.stability.rigid_modes, summary.stability.full_rigid_modes);
    }
    summary.warnings.push_back(
        fmt::format("the full model is {} ({}){}", to_string(fs.verdict), fs.reason, reduced_note));
  }
}

}  // namespace ecmor::run
