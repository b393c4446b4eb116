// `ecmor bench`: the same configured reductions over a ladder of tolerances, one table of order
// reached, errors, times and counters per run. Every run goes through run_reduction exactly as
// `ecmor reduce` would (its outputs land in <output>/runs/<config>_tol<t>/), so a benchmark number
// is always the number a user gets.
#include "bench_run.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "bench_report.hpp"
#include "commands.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/run/config.hpp"
#include "ecmor/run/driver.hpp"
#include "signals.hpp"

namespace ecmor::app {
namespace {

// Exact enough to keep distinct tolerances apart (2e-3 and 2.5e-3), short enough to read.
std::string tol_tag(double t) { return fmt::format("{:.6g}", t); }

/// One configuration of the bench: run over the tolerance ladder under `name` (the run
/// directories' stem).
struct Job {
  RunConfig config;
  std::string name;
};

// Portfolio configs become one job per member (one chart series each) unless --portfolio-as-one;
// --all-reducers makes one job per loaded reducer that accepts the model's kind.
std::vector<Job> expand_jobs(const std::vector<RunConfig>& configs, const BenchOptions& options,
                             const CommonOptions& common) {
  std::vector<Job> jobs;
  auto plain = [](const RunConfig& base, const PortfolioMember& m) {
    RunConfig c = base;
    c.portfolio.clear();
    c.reducer_name = m.reducer_name;
    c.reducer_params = m.reducer_params;
    c.strategy_name = m.strategy_name;
    c.strategy_params = m.strategy_params;
    return c;
  };
  for (const RunConfig& base : configs) {
    const std::string stem = base.source.stem().string();
    if (options.all_reducers) {
      Registry registry;
      load_plugins(registry, common, base.plugins);
      // The kind as load_model decides it (a directory's files or a .mat file's variables).
      const bool second_order = kind_of(load_model(base.model)) == ModelKind::SecondOrder;
      for (const Registry::Entry& e : registry.entries()) {
        if (second_order ? !e.info.second_order : !e.info.descriptor) continue;
        PortfolioMember m;
        m.reducer_name = e.info.name;
        m.reducer_params = ParameterMap("reducer '" + e.info.name + "'");
        m.strategy_name = "grow_order";
        m.strategy_params = base.strategy_name == "grow_order"
                                ? base.strategy_params
                                : ParameterMap("strategy 'grow_order'");
        jobs.push_back({plain(base, m), stem + "_" + e.info.name});
      }
    } else if (!base.portfolio.empty() && !options.portfolio_as_one) {
      for (const PortfolioMember& m : base.portfolio) {
        jobs.push_back({plain(base, m), stem + "_" + m.reducer_name + "_" + m.strategy_name});
      }
    } else {
      jobs.push_back({base, stem});
    }
  }
  if (jobs.empty()) throw ConfigError("ecmor bench: no loaded reducer accepts the models given");
  return jobs;
}

// The row of a finished run: what its summary says.
void record_summary(const RunSummary& s, BenchRow& row) {
  row.termination = to_string(s.termination);
  row.message = s.message;
  row.met = s.termination == Termination::Converged;
  row.n_full = s.full_order;
  row.order = s.has_model ? s.order : 0;
  row.band_error = s.band_error;
  row.verified_error = s.verified_band_error;
  row.f_peak_hz = s.verified_f_peak_hz;
  row.stable = s.stable;
  row.seconds = s.seconds;
  row.reducer_seconds = s.reducer_seconds;
  row.full_response_seconds = s.full_response_seconds;
  row.band_error_seconds = s.band_error_seconds;
  row.reference_seconds = s.reference_seconds;
  const double sparse = s.reducer_counters.factorization_seconds + s.reducer_counters.solve_seconds;
  row.reducer_sparse_share = s.reducer_seconds > 0.0 ? sparse / s.reducer_seconds : 0.0;
  row.sparse_seconds = s.counters.factorization_seconds + s.counters.solve_seconds;
  row.factorizations = s.counters.factorizations;
  row.solves = s.counters.solves;
  row.reducer_factorizations = s.reducer_counters.factorizations;
  row.reducer_solves = s.reducer_counters.solves;
  row.reducer_calls = s.reducer_calls;
  row.iterations = s.iterations;
  row.peak_memory_mb = s.peak_memory_mb;
  row.hinf_error = s.hinf.value;
  row.hinf_scope = s.hinf.scope;
}

// Runs `config` as `ecmor reduce` would and returns its row; a run that throws is a row too
// (termination "error"), not a missing one. Prints the end of the run's progress line.
BenchRow run_one(const RunConfig& config, BenchRow row, const CommonOptions& common,
                 const std::function<double()>& elapsed) {
  try {
    Registry registry;
    load_plugins(registry, common, config.plugins);
    StopOnSignal observer;  // quiet during the run: one progress line when it ends
    record_summary(run_reduction(config, registry, &observer), row);
    fmt::print("{} order {} error {:.2e}, {:.2f} s (reducer {:.3f} s), {:.1f} s elapsed\n",
               row.met ? "met," : row.termination + ",", row.order, row.verified_error, row.seconds,
               row.reducer_seconds, elapsed());
  } catch (const std::exception& e) {
    row.termination = "error";
    row.message = e.what();
    fmt::print("error: {} ({:.1f} s elapsed)\n", e.what(), elapsed());
  }
  return row;
}

}  // namespace

int bench(const BenchOptions& options, const CommonOptions& common) {
  return guarded([&] {
    if (options.configs.empty()) throw ConfigError("ecmor bench: no configuration given");
    for (double t : options.tolerances) {
      if (!(t > 0.0 && t < 1.0)) {
        throw ConfigError(fmt::format("ecmor bench: tolerance {:g}: must be in (0, 1)", t));
      }
    }
    // Load every config first: a typo in the last one must not surface after an hour of runs.
    std::vector<RunConfig> loaded;
    for (const auto& path : options.configs) loaded.push_back(load_run_config(path));
    const std::vector<Job> jobs = expand_jobs(loaded, options, common);
    install_stop_signals();

    const std::filesystem::path out = std::filesystem::absolute(options.output_dir);
    const std::size_t total = jobs.size() * std::max<std::size_t>(options.tolerances.size(), 1);
    std::vector<BenchRow> rows;
    std::set<std::string> used_names;
    bool all_met = true;
    const auto start = std::chrono::steady_clock::now();
    const std::function<double()> elapsed = [&] {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    BenchReport report(out, common.quiet);
    for (const Job& job : jobs) {
      const RunConfig& base = job.config;
      std::vector<double> ladder = options.tolerances;
      if (ladder.empty()) ladder.push_back(base.tolerance);
      for (double tol : ladder) {
        if (stop_signalled()) break;
        RunConfig config = base;
        config.tolerance = tol;
        if (options.time_limit_s > 0.0) config.time_limit_s = options.time_limit_s;
        // One directory per run: configs with the same file name in different folders, or a
        // tolerance given twice, get a numbered suffix instead of overwriting a run's outputs.
        std::string run_name = job.name + "_tol" + tol_tag(tol);
        for (int k = 2; used_names.count(run_name) > 0; ++k) {
          run_name = job.name + "_tol" + tol_tag(tol) + "_" + std::to_string(k);
        }
        used_names.insert(run_name);
        config.output_dir = out / "runs" / run_name;
        BenchRow row;
        row.config = base.source.string();
        row.model = base.model.path.filename().string();
        row.reducer = base.reducer_name;
        row.strategy = base.strategy_name;
        row.tolerance = tol;
        // The elapsed time since the bench started shows while a run goes on.
        fmt::print("[{}/{} {:.1f} s] {} ({} / {}) tolerance {:g} ... ", rows.size() + 1, total,
                   elapsed(), row.model, row.reducer, row.strategy, tol);
        std::fflush(stdout);
        rows.push_back(run_one(config, row, common, elapsed));
        all_met = all_met && rows.back().met;
        report.write(rows);
      }
    }
    fmt::print("\n{}\n{} runs in {:.1f} s; results in {}\n", bench_markdown(rows), rows.size(),
               elapsed(), out.string());
    if (stop_signalled()) return 130;
    return all_met ? 0 : 2;
  });
}

}  // namespace ecmor::app
