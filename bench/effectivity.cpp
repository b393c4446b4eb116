// effectivity.cpp: the estimate mode's error curve against the dense mode's (effectivity.hpp).
#include "effectivity.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "ecmor/model/matrix_market.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/run/driver.hpp"

namespace ecmor::bench {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Value of e.relative at exactly f (NaN when f is not a sample of e).
double relative_at(const BandError& e, double f) {
  const auto it = std::lower_bound(e.f_hz.begin(), e.f_hz.end(), f);
  if (it == e.f_hz.end() || *it != f) return std::numeric_limits<double>::quiet_NaN();
  return e.relative[static_cast<std::size_t>(it - e.f_hz.begin())];
}

bool same_basis(const Matrix& a, const Matrix& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() && a == b;
}

std::string number(double v, const char* format = "{:.2e}") {
  if (std::isnan(v)) return "-";
  return fmt::format(fmt::runtime(format), v);
}

}  // namespace

double EffectivityReport::estimate_ratio() const {
  return true_sup > 0.0 ? estimate_sup / true_sup : kNaN;
}

double EffectivityReport::certified_ratio() const {
  return true_sup > 0.0 ? certified / true_sup : kNaN;
}

std::string EffectivityReport::peak_located() const {
  if (peak_frequency_located && peak_value_located) return "both";
  if (peak_frequency_located) return "freq";
  if (peak_value_located) return "value";
  return "no";
}

EffectivityReport measure_effectivity(const Model& model, const Band& band,
                                      BandErrorOptions options, const ReducedModel& reduced,
                                      const Matrix& V, const Matrix& W,
                                      const SolverOptions& solver_options, int threads,
                                      Index verify_factor) {
  EffectivityReport r;
  r.full_order = size_of(model);
  r.order = size_of(reduced);

  // 1. The estimate mode, as a run would see the final model (offered its own bases).
  const auto t_estimate = Clock::now();
  auto estimate_solver = make_shifted_solver(model, solver_options);
  ResponseCache estimate_cache(model, *estimate_solver, threads);
  options.verify = ErrorVerify::Estimate;
  BandErrorEstimator estimate(estimate_cache, band, options);
  if (V.rows() == r.full_order) estimate.offer_basis(V);
  if (W.rows() == r.full_order && !same_basis(V, W)) estimate.offer_basis(W);
  const BandError guess = estimate.evaluate(reduced);
  r.estimate_sup = guess.sup_relative;
  r.estimate_f_peak_hz = guess.f_peak_hz;
  r.estimate_solves = estimate_cache.size();
  r.reference_order = guess.reference_order;
  r.estimate_seconds = seconds_since(t_estimate);

  // 2. The dense mode on its own cache: its verify() (counted as its cost), then the true error
  // at the estimate's samples.
  const auto t_dense = Clock::now();
  auto dense_solver = make_shifted_solver(model, solver_options);
  ResponseCache dense_cache(model, *dense_solver, threads);
  options.verify = ErrorVerify::Dense;
  BandErrorEstimator dense(dense_cache, band, options);
  const BandError truth = dense.verify(reduced, verify_factor);
  r.dense_solves = dense_cache.size();
  r.dense_seconds = seconds_since(t_dense);
  r.dense_verify_sup = truth.sup_relative;
  r.dense_verify_f_peak_hz = truth.f_peak_hz;
  const BandError on_samples = dense.evaluate_on(reduced, guess.f_hz);
  r.true_sup = truth.sup_relative;
  r.true_f_peak_hz = truth.f_peak_hz;
  if (on_samples.sup_relative > r.true_sup) {
    r.true_sup = on_samples.sup_relative;
    r.true_f_peak_hz = on_samples.f_peak_hz;
  }

  std::vector<double> ratios, near;
  for (std::size_t k = 0; k < guess.f_hz.size(); ++k) {
    if (k < guess.exact.size() && guess.exact[k]) continue;
    const double est = guess.relative[k];
    const double tru = relative_at(on_samples, guess.f_hz[k]);
    if (!(tru > 0.0) || !std::isfinite(tru) || !std::isfinite(est)) continue;
    ratios.push_back(est / tru);
    if (tru >= 0.1 * r.true_sup) near.push_back(est / tru);
  }
  std::sort(ratios.begin(), ratios.end());
  std::sort(near.begin(), near.end());
  r.effectivity_count = static_cast<Index>(ratios.size());
  if (!ratios.empty()) {
    r.effectivity_min = ratios.front();
    r.effectivity_max = ratios.back();
    const std::size_t n = ratios.size();
    r.effectivity_median = n % 2 == 1 ? ratios[n / 2] : 0.5 * (ratios[n / 2 - 1] + ratios[n / 2]);
  }
  r.near_peak_count = static_cast<Index>(near.size());
  if (!near.empty()) {
    r.near_peak_min = near.front();
    r.near_peak_max = near.back();
  }

  // 3. The estimate where the truth peaks, then the estimate mode's certified value.
  const auto t_certify = Clock::now();
  const BandError at_peak = estimate.evaluate_on(reduced, {r.true_f_peak_hz});
  r.estimate_at_true_peak =
      at_peak.relative.empty() ? EffectivityReport::kNaN : at_peak.relative[0];
  r.peak_frequency_located =
      std::abs(r.estimate_f_peak_hz - r.true_f_peak_hz) <= 0.01 * r.true_f_peak_hz;
  r.peak_value_located =
      r.estimate_at_true_peak >= 0.5 * r.true_sup && r.estimate_at_true_peak <= 2.0 * r.true_sup;
  const BandError certified = estimate.verify(reduced, verify_factor);
  r.certified = certified.sup_relative;
  r.certified_f_peak_hz = certified.f_peak_hz;
  r.estimate_solves_with_verify = estimate_cache.size();
  r.estimate_seconds += seconds_since(t_certify);
  return r;
}

void load_plugins_for(Registry& registry, const RunConfig& config,
                      const std::vector<std::filesystem::path>& extra_dirs) {
  for (const auto& dir : default_plugin_directories()) registry.load_directory(dir);
  for (const auto& dir : extra_dirs) registry.load_directory(dir);
  for (const auto& path : config.plugins) {
    if (std::filesystem::is_directory(path)) {
      for (const std::string& problem : registry.load_directory(path))
        throw std::runtime_error(problem);
    } else {
      registry.load_plugin(path);
    }
  }
}

DriverRun reduce_with_driver(RunConfig config, Registry& registry,
                             const std::filesystem::path& output_dir) {
  config.output_dir = output_dir;
  const auto t0 = Clock::now();
  const RunSummary summary = run_reduction(config, registry);
  DriverRun run;
  run.seconds = seconds_since(t0);
  run.termination = to_string(summary.termination);
  run.verified_band_error = summary.verified_band_error;
  if (!summary.has_model) {
    throw std::runtime_error(fmt::format("{}: the run wrote no model ({}: {})",
                                         config.source.string(), run.termination, summary.message));
  }
  run.reduced = read_reduced_model(output_dir);
  if (std::filesystem::exists(output_dir / "V.mtx"))
    run.V = read_matrix_market_dense(output_dir / "V.mtx");
  if (std::filesystem::exists(output_dir / "W.mtx"))
    run.W = read_matrix_market_dense(output_dir / "W.mtx");
  return run;
}

std::string effectivity_row(const EffectivityReport& r) {
  const char* const ratio = "{:#.3g}";
  std::string row = fmt::format("| {} | {} | {} | {} | {} | {} | {} | ", r.name, r.full_order,
                                r.order, r.reference_order, number(r.estimate_sup),
                                number(r.true_sup), number(r.estimate_ratio(), ratio));
  row += fmt::format(
      "{} | {} / {} / {} | {} / {} | {} ({}) | ", r.effectivity_count,
      number(r.effectivity_min, ratio), number(r.effectivity_median, ratio),
      number(r.effectivity_max, ratio), number(r.near_peak_min, ratio),
      number(r.near_peak_max, ratio), r.peak_located(),
      number(r.true_sup > 0.0 ? r.estimate_at_true_peak / r.true_sup : EffectivityReport::kNaN,
             ratio));
  row += fmt::format("{} | {} | {} / {} / {} | {} / {} / {} |\n", number(r.certified),
                     number(r.certified_ratio(), ratio), r.estimate_solves,
                     r.estimate_solves_with_verify, r.dense_solves,
                     number(r.reduction_seconds, "{:.1f}"), number(r.estimate_seconds, "{:.1f}"),
                     number(r.dense_seconds, "{:.1f}"));
  return row;
}

std::string effectivity_table(const std::vector<EffectivityReport>& reports) {
  std::string out =
      "| model | N | order | reference order | estimate sup | true sup | est / true | samples | "
      "effectivity min / median / max | near peak min / max | "
      "peak located (est / true at true peak) | certified | cert / true | "
      "full solves evaluate / +verify / dense | seconds reduce / estimate / dense |\n"
      "|---|---:|---:|---:|---:|---:|---:|---:|---|---|---|---:|---:|---|---|\n";
  for (const EffectivityReport& r : reports) out += effectivity_row(r);
  return out;
}

}  // namespace ecmor::bench
