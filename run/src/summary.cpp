// summary.cpp: summary.json, written from the one RunSummary (summary.hpp).
#include "ecmor/run/summary.hpp"

#include <cmath>
#include <nlohmann/json.hpp>

#include "ecmor/run/history.hpp"
#include "ecmor/version.hpp"

namespace ecmor {
namespace {

nlohmann::json counters_json(const SolverCounters& c) {
  nlohmann::json j = nlohmann::json::object();
  for_each_counter(c, [&](const char* name, auto value) { j[name] = value; });
  return j;
}

nlohmann::json number_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

/// The memory plan made before the first numeric factorisation and the peak measured at the end.
nlohmann::json memory_json(const MemoryPlan& p, double peak_mb) {
  constexpr double kMiB = 1048576.0;
  nlohmann::json j = {{"predicted", p.predicted}, {"method", p.method}, {"peak_mb", peak_mb}};
  if (!p.predicted) return j;
  j["factor_mb"] = p.factor_bytes / kMiB;
  j["factor_entries"] = p.factor_entries;
  j["concurrent"] = p.concurrent;
  j["kept"] = p.kept;
  j["reuse_limit"] = p.reuse_limit;
  j["resident_before_mb"] = p.headroom.resident_bytes / kMiB;
  j["predicted_peak_mb"] = p.peak_bytes() / kMiB;
  j["headroom_mb"] = p.headroom.bytes / kMiB;
  j["limit"] = p.headroom.limit;
  j["adjustments"] = p.adjustments;
  return j;
}

/// The checks of the reported model (acceptance.cpp, check_reported_model).
void add_model_checks(const RunSummary& s, nlohmann::json& j) {
  const HinfReport& h = s.hinf;
  j["hinf_error"] = {
      {"value", h.value},
      {"scope", h.scope},
      {"certified", h.certified},
      {"f_peak_hz", h.f_peak_hz >= 0.0 ? nlohmann::json(h.f_peak_hz) : nlohmann::json(nullptr)},
      {"method", h.method},
      {"seconds", h.seconds}};
  j["undefined_frequencies_hz"] = s.undefined_frequencies_hz;
  j["sampling"] = {{"estimator", s.estimator_sampling}, {"verify", s.verify_sampling}};
  // What the accepted error rests on: every frequency where the full model was solved (all of
  // them enter the check), and how well the estimate predicted the error there.
  const ErrorControlReport& e = s.error_control;
  const bool estimate_mode = e.mode == to_string(ErrorVerify::Estimate);
  j["error_control"] = {
      {"mode", e.mode},
      {"switch", e.mode_switch.empty() ? nlohmann::json(nullptr) : nlohmann::json(e.mode_switch)},
      {"escalation",
       e.escalation.empty() ? nlohmann::json(nullptr) : nlohmann::json(e.escalation)},
      {"reference_order", e.reference_order},
      {"checked_frequencies", e.checked_frequencies},
      {"checked_f_hz", estimate_mode ? nlohmann::json(e.checked_f_hz) : nlohmann::json(nullptr)},
      {"estimate_sup_unchecked", number_or_null(e.estimate_sup_unchecked)},
      {"reference_floor", e.reference_floor},
      {"effectivity",
       {{"count", e.effectivity_count},
        {"min", number_or_null(e.effectivity_min)},
        {"median", number_or_null(e.effectivity_median)},
        {"max", number_or_null(e.effectivity_max)}}}};
  j["points"] = nlohmann::json::array();
  for (const ExpansionPoint& p : s.points) {
    j["points"].push_back({{"re", p.s.real()}, {"im", p.s.imag()}, {"moments", p.moments}});
  }
}

/// The full model's stability and, with a model, the reduced model's (acceptance.cpp).
void add_stability(const RunSummary& s, nlohmann::json& j) {
  const StabilityReport& fs = s.full_stability;
  j["full_model_stability"] = {
      {"verdict", to_string(fs.verdict)},
      {"method", fs.method},
      {"reason", fs.reason},
      {"max_real_pole", fs.dense ? nlohmann::json(fs.max_real_pole) : nlohmann::json(nullptr)},
      {"seconds", s.full_stability_seconds}};
  if (s.has_model) {
    const ReducedStability& st = s.stability;
    j["stability"] = {{"verdict", st.label},
                      {"accepted", st.accepted()},
                      {"reason", st.reason},
                      {"rigid_modes", st.rigid_modes},
                      {"full_rigid_modes", st.full_rigid_modes},
                      {"zero_radius_rad_s", st.zero_radius},
                      {"poles_at_zero", st.zero_poles},
                      {"full_rigid_method", s.full_rigid_method},
                      {"full_rigid_seconds", s.full_rigid_seconds}};
  }
  j["warnings"] = s.warnings;
}

}  // namespace

int RunSummary::exit_code() const {
  if (termination == Termination::Converged) return 0;
  return has_model ? 2 : 1;
}

std::string RunSummary::to_json() const {
  nlohmann::json j;
  j["ecmor_version"] = ECMOR_VERSION_STRING;
  j["config"] = config.string();
  j["termination"] = to_string(termination);
  j["message"] = message;
  j["target_met"] = termination == Termination::Converged;
  j["has_model"] = has_model;
  j["final_order"] = order;
  j["band_error"] = band_error;
  j["f_peak_hz"] = f_peak_hz;
  j["verified_band_error"] = verified_band_error;
  j["verified_f_peak_hz"] = verified_f_peak_hz;
  j["verify_factor"] = verify_factor;
  j["band_hinf_absolute_error"] = hinf_absolute;
  j["band_h2_absolute_error"] = h2_absolute;
  j["stable"] = stable;
  j["tolerance"] = tolerance;
  j["norm"] = to_string(norm);
  j["band"] = {{"f_min_hz", band.f_min_hz}, {"f_max_hz", band.f_max_hz}};
  // The model as the YAML named it: `dir`, or `file` with the renamed `variables`.
  if (model.path.empty()) {
    j["model"] = {{"memory", true}};  // given in memory (the Python module), read from no file
  } else if (is_mat_path(model.path)) {
    j["model"] = {{"file", model.path.string()}, {"variables", model.variables}};
  } else {
    j["model"] = {{"dir", model.path.string()}};
  }
  j["model"].update({{"kind", to_string(model_kind)},
                     {"N", full_order},
                     {"inputs", inputs},
                     {"outputs", outputs}});
  j["backend"] = {{"name", backend}, {"solver", solver}, {"ranks", ranks}};
  j["reducer"] = configured_reducer;
  j["strategy"] = configured_strategy;
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
    j["portfolio"] = {{"winner", winner >= 0 ? nlohmann::json(reducer + "/" + strategy)
                                             : nlohmann::json(nullptr)},
                      {"prune", portfolio_prune},
                      {"race", portfolio_race},
                      {"members", list}};
  }
  const CompressionReport& c = compression;
  j["compression"] = {
      {"enabled", compress},
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
  j["iterations"] = iterations;
  j["seconds"] = {{"total", seconds},
                  {"load", load_seconds},
                  {"reducer", reducer_seconds},
                  {"full_response", full_response_seconds},
                  {"band_error", band_error_seconds},
                  {"reference_model", reference_seconds}};
  j["reducer_calls"] = reducer_calls;
  j["reducer_counters"] = counters_json(reducer_counters);
  j["reducer_reused_factorizations"] = reducer_reused_factorizations;
  j["counters"] = counters_json(counters);
  j["full_evaluations"] = full_evaluations;
  j["peak_memory_mb"] = peak_memory_mb;
  j["memory"] = memory_json(memory_plan, peak_memory_mb);
  const ThreadBudget& t = threads;
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
  if (has_model) add_model_checks(*this, j);
  add_stability(*this, j);
  return j.dump(2) + "\n";
}

}  // namespace ecmor
