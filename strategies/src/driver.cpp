#include "ecmor/strategies/driver.hpp"

#include <sys/resource.h>

#include <chrono>
#include <fstream>
#include <iomanip>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "ecmor/atomic_file.hpp"
#include "ecmor/error.hpp"
#include "ecmor/frequency_response.hpp"
#include "ecmor/matrix_market.hpp"
#include "ecmor/model_io.hpp"
#include "ecmor/version.hpp"

namespace ecmor {

int RunSummary::exit_code() const {
  if (termination == Termination::Converged) return 0;
  return has_model ? 2 : 1;
}

double peak_memory_mb() {
  struct rusage usage {};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB on Linux
}

namespace {

nlohmann::json counters_json(const SolverCounters& c) {
  nlohmann::json j = nlohmann::json::object();
  for_each_counter(c, [&](const char* name, auto value) { j[name] = value; });
  return j;
}

// The verified error curve, for plots and for users who want to look rather than read.
void write_error_curve(const std::filesystem::path& path, const BandError& e) {
  write_file_atomically(path, [&](std::ostream& os) {
    os << "f_hz,relative_spectral,relative_frobenius,absolute_spectral,reference_spectral\n";
    os << std::setprecision(10);
    for (std::size_t k = 0; k < e.f_hz.size(); ++k) {
      os << e.f_hz[k] << ',' << e.relative_spectral[k] << ',' << e.relative_frobenius[k] << ','
         << e.absolute[k] << ',' << e.reference[k] << '\n';
    }
  });
}

bool all_poles_stable(const ReducedModel& m) {
  const ComplexVector p = poles(m);
  for (Index i = 0; i < p.size(); ++i) {
    if (!(p(i).real() < 0.0)) return false;
  }
  return true;
}

}  // namespace

namespace {

/// Wraps the configured reducer to measure the reduction proper: wall time and solver work inside
/// reduce(), apart from the error estimation around it.
class TimedReducer final : public Reducer {
 public:
  TimedReducer(Reducer& inner, const ShiftedSolver& solver) : m_inner(inner), m_solver(solver) {}
  void setup(const ReductionContext& context) override { m_inner.setup(context); }
  ReducerResult reduce(const ReductionRequest& request) override {
    const auto start = std::chrono::steady_clock::now();
    const SolverCounters before = m_solver.counters();
    // Counted even when reduce() throws: the work was done.
    struct Account {
      TimedReducer& self;
      std::chrono::steady_clock::time_point start;
      SolverCounters before;
      ~Account() {
        self.m_seconds +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        self.m_counters += self.m_solver.counters() - before;
        ++self.m_calls;
      }
    } account{*this, start, before};
    return m_inner.reduce(request);
  }
  Index max_order() const override { return m_inner.max_order(); }
  Index order_step() const override { return m_inner.order_step(); }

  double seconds() const { return m_seconds; }
  Index calls() const { return m_calls; }
  const SolverCounters& counters() const { return m_counters; }

 private:
  Reducer& m_inner;
  const ShiftedSolver& m_solver;
  double m_seconds = 0.0;
  Index m_calls = 0;
  SolverCounters m_counters;
};

}  // namespace

RunSummary run_reduction(const RunConfig& config, Registry& registry, RunObserver* observer) {
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };

  const Model model = load_model(config.model_dir);
  const double load_seconds = elapsed();
  if (observer) observer->on_model_loaded(config, model, load_seconds);

  // Bad configuration is found before any heavy work.
  std::shared_ptr<Reducer> reducer = registry.create(config.reducer_name, config.reducer_params);
  std::unique_ptr<Strategy> strategy = make_strategy(config.strategy_name, config.strategy_params);
  ReducerInfo reducer_info;
  for (const Registry::Entry& e : registry.entries()) {
    if (e.info.name == config.reducer_name) reducer_info = e.info;
  }
  if (strategy->moves_points() && !reducer_info.uses_expansion_points) {
    throw ConfigError(config.source.string() + ": strategy '" + config.strategy_name +
                      "' moves expansion points, but reducer '" + config.reducer_name +
                      "' does not use them; use strategy grow_order with it");
  }

  std::unique_ptr<ShiftedSolver> solver = make_shifted_solver(model, config.solver);
  ResponseCache cache(model, *solver, config.threads);
  BandErrorOptions error_options = config.error;
  error_options.norm = config.norm;
  BandErrorEstimator estimator(cache, config.band, error_options);

  reducer->setup(ReductionContext{&model, solver.get(), config.band});
  TimedReducer timed(*reducer, *solver);

  HistoryWriter history(config.output_dir);
  StrategyContext ctx;
  ctx.reducer = &timed;
  ctx.reducer_info = reducer_info;
  ctx.estimator = &estimator;
  ctx.tolerance = config.tolerance;
  ctx.verify_factor = config.verify_factor;
  ctx.start = start;
  ctx.counters = [&] { return solver->counters(); };
  ctx.full_evaluations = [&] { return cache.size(); };
  // The time limit acts as an interrupt: strategies poll stop_requested() and finish with the
  // best model so far; the message then says which of the two ended the run.
  bool out_of_time = false;
  auto time_is_up = [&] {
    if (config.time_limit_s > 0.0 && elapsed() > config.time_limit_s) out_of_time = true;
    return out_of_time;
  };
  ctx.stop_requested = [&] {
    return time_is_up() || (observer != nullptr && observer->stop_requested());
  };
  ctx.on_iteration = [&](const IterationRecord& rec) {
    IterationRecord with_memory = rec;
    with_memory.diagnostics["peak_memory_mb"] = peak_memory_mb();
    history.append(with_memory);
    const bool go_on = observer ? observer->on_iteration(with_memory) : true;
    return !time_is_up() && go_on;
  };

  StrategyResult result = strategy->run(ctx);
  if (out_of_time && result.termination == Termination::Interrupted) {
    result.message = fmt::format("time limit strategy.time_limit_s = {} s used up: {}",
                                 config.time_limit_s, result.message);
  }

  RunSummary summary;
  summary.termination = result.termination;
  summary.message = result.message;
  summary.tolerance = config.tolerance;
  summary.output_dir = config.output_dir;
  summary.iterations = static_cast<Index>(result.history.size());
  summary.load_seconds = load_seconds;
  summary.full_order = size_of(model);

  nlohmann::json j;
  if (result.best) {
    const ReducerResult& best = *result.best;
    write_reduced_model(config.output_dir, best.model);
    write_matrix_market(config.output_dir / "V.mtx", best.V, "right projection basis V");
    write_matrix_market(config.output_dir / "W.mtx", best.W, "left projection basis W");
    // The reported model is always re-checked on the independent grid, converged or not.
    const BandError verified = estimator.verify(best.model, config.verify_factor);
    write_error_curve(config.output_dir / "band_error.csv", verified);
    summary.has_model = true;
    summary.order = best.V.cols();
    summary.band_error = result.best_error.sup_relative;
    summary.f_peak_hz = result.best_error.f_peak_hz;
    summary.verified_band_error = verified.sup_relative;
    summary.verified_f_peak_hz = verified.f_peak_hz;
    summary.hinf_absolute = verified.hinf_absolute;
    summary.h2_absolute = verified.h2_absolute;
    summary.stable = all_poles_stable(best.model);
    if (summary.termination == Termination::Converged &&
        verified.sup_relative > config.tolerance) {
      // Cannot happen for strategies that verify before accepting; guard the contract anyway.
      summary.termination = Termination::Failed;
      summary.message = "reported model fails the independent re-check: " + result.message;
    }
    j["undefined_frequencies_hz"] = verified.undefined_f_hz;
    j["sampling"] = {{"estimator", result.best_error.sampling()}, {"verify", verified.sampling()}};
    j["points"] = nlohmann::json::array();
    for (const ExpansionPoint& p : best.points) {
      j["points"].push_back({{"re", p.s.real()}, {"im", p.s.imag()}, {"moments", p.moments}});
    }
  }
  summary.counters = solver->counters();
  summary.reducer_seconds = timed.seconds();
  summary.reducer_calls = timed.calls();
  summary.reducer_counters = timed.counters();
  summary.full_response_seconds = cache.seconds();
  summary.full_evaluations = cache.size();
  summary.seconds = elapsed();
  summary.peak_memory_mb = peak_memory_mb();

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
  j["model"] = {{"dir", config.model_dir.string()},
                {"kind", to_string(kind_of(model))},
                {"N", size_of(model)},
                {"inputs", inputs_of(model)},
                {"outputs", outputs_of(model)}};
  j["reducer"] = config.reducer_name;
  j["strategy"] = config.strategy_name;
  j["iterations"] = summary.iterations;
  j["seconds"] = {{"total", summary.seconds},
                  {"load", summary.load_seconds},
                  {"reducer", summary.reducer_seconds},
                  {"full_response", summary.full_response_seconds}};
  j["reducer_calls"] = summary.reducer_calls;
  j["reducer_counters"] = counters_json(summary.reducer_counters);
  j["counters"] = counters_json(summary.counters);
  j["full_evaluations"] = summary.full_evaluations;
  j["peak_memory_mb"] = summary.peak_memory_mb;
  write_text_atomically(config.output_dir / "summary.json", j.dump(2) + "\n");

  if (observer) observer->on_finished(summary);
  return summary;
}

}  // namespace ecmor
