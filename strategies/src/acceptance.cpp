#include "acceptance.hpp"

#include <fmt/format.h>

#include <cmath>
#include <iomanip>

#include "ecmor/base/atomic_file.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/threads.hpp"
#include "ecmor/gramians/lyapunov.hpp"
#include "ecmor/linalg/parallel.hpp"
#include "ecmor/measures/hinf_norm.hpp"
#include "ecmor/model/dense_model.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/version.hpp"

namespace ecmor::driver {
namespace {

nlohmann::json counters_json(const SolverCounters& c) {
  nlohmann::json j = nlohmann::json::object();
  for_each_counter(c, [&](const char* name, auto value) { j[name] = value; });
  return j;
}

}  // namespace

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

namespace {

struct HinfReport {
  double value = 0.0;
  double f_peak_hz = -1.0;  ///< < 0: not known
  bool certified = false;
  std::string scope, method;
};

// The error system's H-infinity norm, stating how it was obtained: exact (certified level-set
// bracket over all frequencies) for small full models, else the sampled band supremum.
HinfReport hinf_of_error(const Model& full, const ReducedModel& reduced, const BandError& verified,
                         Index dense_states) {
  HinfReport r;
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
  return r;
}

}  // namespace

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

nlohmann::json accept_model(const StrategyResult& result, const RunConfig& config,
                            const Model& model, BandErrorEstimator& estimator,
                            const ResponseCache& cache, const RigidBodyModes& rigid,
                            std::chrono::steady_clock::time_point start, RunSummary& summary,
                            BandError& verified) {
  nlohmann::json j;
  const ReducerResult& best = *result.best;
  // The reported model is always re-checked independently, converged or not (a stop request
  // no longer applies here: the check of the model being written is part of writing it). A
  // compressed model was re-checked by its compression, which is not repeated.
  verified =
      result.best_checked ? result.best_error : estimator.verify(best.model, config.verify_factor);
  summary.has_model = true;
  summary.order = best.V.cols();
  // Estimate mode: the reported error is the re-check's, measured against the full model at
  // every frequency it solved; the strategy's value of a model that never passed is an estimate.
  const bool estimate_mode = estimator.mode() == ErrorVerify::Estimate;
  summary.band_error = estimate_mode ? verified.sup_relative : result.best_error.sup_relative;
  summary.f_peak_hz = estimate_mode ? verified.f_peak_hz : result.best_error.f_peak_hz;
  summary.verified_band_error = verified.sup_relative;
  summary.error_mode = to_string(estimator.mode());
  summary.error_mode_switch = estimator.switch_note();
  summary.checked_frequencies = verified.checked_samples;
  summary.verified_f_peak_hz = verified.f_peak_hz;
  summary.hinf_absolute = verified.hinf_absolute;
  summary.h2_absolute = verified.h2_absolute;
  summary.stability = reduced_model_stability(best.model, rigid);
  summary.stable = summary.stability.accepted();
  const double hinf_start = seconds_since(start);
  const HinfReport hinf = hinf_of_error(model, best.model, verified, config.hinf_dense_states);
  const double hinf_seconds = seconds_since(start) - hinf_start;
  summary.hinf_error = hinf.value;
  summary.hinf_method = hinf.method;
  summary.hinf_scope = hinf.scope;
  j["hinf_error"] = {{"value", hinf.value},
                     {"scope", hinf.scope},
                     {"certified", hinf.certified},
                     {"f_peak_hz", hinf.f_peak_hz >= 0.0 ? nlohmann::json(hinf.f_peak_hz)
                                                         : nlohmann::json(nullptr)},
                     {"method", hinf.method},
                     {"seconds", hinf_seconds}};
  if (summary.termination == Termination::Converged && !verified.within(config.tolerance)) {
    // Cannot happen for strategies that verify before accepting; guard the contract anyway.
    summary.termination = Termination::Failed;
    summary.message = "reported model fails the independent re-check: " + result.message;
  }
  j["undefined_frequencies_hz"] = verified.undefined_f_hz;
  j["sampling"] = {{"estimator", result.best_error.sampling()}, {"verify", verified.sampling()}};
  // What the accepted error rests on: every frequency where the full model was solved (all of
  // them enter the check), and how well the estimate predicted the error there.
  auto number_or_null = [](double v) {
    return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
  };
  j["error_control"] = {
      {"mode", to_string(estimator.mode())},
      {"switch", estimator.switch_note().empty() ? nlohmann::json(nullptr)
                                                 : nlohmann::json(estimator.switch_note())},
      {"reference_order", estimator.reference_order()},
      {"checked_frequencies", verified.checked_samples},
      {"checked_f_hz",
       estimate_mode ? nlohmann::json(cache.frequencies()) : nlohmann::json(nullptr)},
      {"estimate_sup_unchecked", number_or_null(verified.estimate_sup)},
      {"reference_floor", verified.reference_floor},
      {"effectivity",
       {{"count", verified.effectivity_count},
        {"min", number_or_null(verified.effectivity_min)},
        {"median", number_or_null(verified.effectivity_median)},
        {"max", number_or_null(verified.effectivity_max)}}}};
  j["points"] = nlohmann::json::array();
  for (const ExpansionPoint& p : best.points) {
    j["points"].push_back({{"re", p.s.real()}, {"im", p.s.imag()}, {"moments", p.moments}});
  }
  return j;
}

nlohmann::json report_stability(const RunConfig& config, const Model& model,
                                const RigidBodyModes& rigid, double rigid_seconds,
                                std::chrono::steady_clock::time_point start, RunSummary& summary) {
  nlohmann::json j;
  // The full model's own stability, after the reduction so that a refusal or bad configuration is
  // reported first; dense for small models, structural (K, D inertia) for large second-order ones.
  const double stability_start = seconds_since(start);
  summary.full_stability = full_model_stability(model, config.stability_dense_states, rigid);
  const double stability_seconds = seconds_since(start) - stability_start;
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
  j["full_model_stability"] = {
      {"verdict", to_string(fs.verdict)},
      {"method", fs.method},
      {"reason", fs.reason},
      {"max_real_pole", fs.dense ? nlohmann::json(fs.max_real_pole) : nlohmann::json(nullptr)},
      {"seconds", stability_seconds}};
  if (summary.has_model) {
    const ReducedStability& st = summary.stability;
    j["stability"] = {{"verdict", st.label},
                      {"accepted", st.accepted()},
                      {"reason", st.reason},
                      {"rigid_modes", st.rigid_modes},
                      {"full_rigid_modes", st.full_rigid_modes},
                      {"zero_radius_rad_s", st.zero_radius},
                      {"poles_at_zero", st.zero_poles},
                      {"full_rigid_method", rigid.describe()},
                      {"full_rigid_seconds", rigid_seconds}};
  }
  j["warnings"] = summary.warnings;
  return j;
}

nlohmann::json summary_json(const RunSummary& summary, const RunConfig& config, const Model& model,
                            const std::string& solver_backend, int winner) {
  nlohmann::json j;
  const bool portfolio = !config.portfolio.empty();
  const std::vector<PortfolioAttempt>& attempts = summary.attempts;
  j["ecmor_version"] = ECMOR_VERSION_STRING;
  j["config"] = config.source.string();
  j["termination"] = to_string(summary.termination);
  j["message"] = summary.message;
  j["target_met"] = summary.termination == Termination::Converged;
  j["has_model"] = summary.has_model;
  j["final_order"] = summary.order;
  j["band_error"] = summary.band_error;
  j["f_peak_hz"] = summary.f_peak_hz;
  j["verified_band_error"] = summary.verified_band_error;
  j["verified_f_peak_hz"] = summary.verified_f_peak_hz;
  j["verify_factor"] = config.verify_factor;
  j["band_hinf_absolute_error"] = summary.hinf_absolute;
  j["band_h2_absolute_error"] = summary.h2_absolute;
  j["stable"] = summary.stable;
  j["tolerance"] = config.tolerance;
  j["norm"] = to_string(config.norm);
  j["band"] = {{"f_min_hz", config.band.f_min_hz}, {"f_max_hz", config.band.f_max_hz}};
  // The model as the YAML named it: `dir`, or `file` with the renamed `variables`.
  if (config.model.path.empty()) {
    j["model"] = {{"memory", true}};  // given in memory (the Python module), read from no file
  } else if (is_mat_path(config.model.path)) {
    j["model"] = {{"file", config.model.path.string()}, {"variables", config.model.variables}};
  } else {
    j["model"] = {{"dir", config.model.path.string()}};
  }
  j["model"].update({{"kind", to_string(kind_of(model))},
                     {"N", size_of(model)},
                     {"inputs", inputs_of(model)},
                     {"outputs", outputs_of(model)}});
  j["backend"] = {
      {"name", config.solver.backend}, {"solver", solver_backend}, {"ranks", process_count()}};
  j["reducer"] = config.reducer_name;
  j["strategy"] = config.strategy_name;
  if (portfolio) {
    nlohmann::json list = nlohmann::json::array();
    for (const PortfolioAttempt& a : attempts) {
      list.push_back({{"reducer", a.reducer},
                      {"strategy", a.strategy},
                      {"termination", a.termination},
                      {"message", a.message},
                      {"target_met", a.met},
                      {"has_model", a.has_model},
                      {"order", a.order},
                      {"band_error", a.band_error},
                      {"seconds", a.seconds},
                      {"reducer_seconds", a.reducer_seconds},
                      {"iterations", a.iterations},
                      {"selected", a.selected}});
    }
    j["portfolio"] = {
        {"winner", winner >= 0 ? nlohmann::json(summary.reducer + "/" + summary.strategy)
                               : nlohmann::json(nullptr)},
        {"prune", config.portfolio_prune},
        {"race", config.portfolio_race},
        {"members", list}};
  }
  const CompressionReport& c = summary.compression;
  j["compression"] = {
      {"enabled", config.compress},
      {"attempted", c.attempted},
      {"applied", c.applied},
      {"method", c.attempted ? nlohmann::json(c.method) : nlohmann::json(nullptr)},
      {"note", c.note},
      {"order_before", c.order_before},
      {"order_after", c.order_after},
      {"states_saved", c.order_before - c.order_after},
      {"error_before", c.error_before},
      {"error_after", c.applied ? nlohmann::json(c.error_after) : nlohmann::json(nullptr)},
      {"candidates", c.candidates},
      {"verifications", c.verifications},
      {"factorizations", c.factorizations},
      {"seconds", c.seconds}};
  j["iterations"] = summary.iterations;
  j["seconds"] = {{"total", summary.seconds},
                  {"load", summary.load_seconds},
                  {"reducer", summary.reducer_seconds},
                  {"full_response", summary.full_response_seconds},
                  {"band_error", summary.band_error_seconds},
                  {"reference_model", summary.reference_seconds}};
  j["reducer_calls"] = summary.reducer_calls;
  j["reducer_counters"] = counters_json(summary.reducer_counters);
  j["reducer_reused_factorizations"] = summary.reducer_reused_factorizations;
  j["counters"] = counters_json(summary.counters);
  j["full_evaluations"] = summary.full_evaluations;
  j["peak_memory_mb"] = summary.peak_memory_mb;
  const ThreadBudget& t = summary.threads;
  const BlasInfo blas = blas_info();
  j["threads"] = {{"cores", t.cores},
                  {"limit", t.limit},
                  {"source", t.source},
                  {"adaptive", t.adaptive},
                  {"fewest_used", t.fewest_used},
                  {"most_used", t.most_used},
                  {"load_reductions", t.load_reductions},
                  {"blas", blas.name},
                  {"blas_threading", blas.threading}};
  return j;
}

}  // namespace ecmor::driver
