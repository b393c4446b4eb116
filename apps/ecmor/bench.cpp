// `ecmor bench`: the same configured reductions over a ladder of tolerances, one table of order
// reached, errors, times and counters per run. Every run goes through run_reduction exactly as
// `ecmor reduce` would (its outputs land in <output>/runs/<config>_tol<t>/), so a benchmark number
// is always the number a user gets.
#include <fmt/core.h>
#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <algorithm>
#include <csignal>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "commands.hpp"
#include "ecmor/atomic_file.hpp"
#include "ecmor/config.hpp"
#include "ecmor/error.hpp"
#include "ecmor/registry.hpp"
#include "ecmor/strategies/driver.hpp"

namespace ecmor::app {
namespace {

struct BenchRow {
  std::string config, model, reducer, strategy;
  Index n_full = 0;
  double tolerance = 0.0;
  std::string termination;
  std::string message;
  bool met = false;
  Index order = 0;
  double band_error = 0.0, verified_error = 0.0, f_peak_hz = 0.0;
  bool stable = false;
  double seconds = 0.0, reducer_seconds = 0.0, full_response_seconds = 0.0;
  /// Share of the reducer's time spent in sparse factorisations and solves.
  double reducer_sparse_share = 0.0;
  /// Seconds in sparse factorisations and solves over the whole run (summed over threads).
  double sparse_seconds = 0.0;
  Index factorizations = 0, solves = 0, reducer_factorizations = 0, reducer_solves = 0;
  Index reducer_calls = 0, iterations = 0;
  double peak_memory_mb = 0.0;
};

std::atomic<bool> g_bench_interrupted{false};
extern "C" void on_bench_signal(int) { g_bench_interrupted.store(true); }

// Quiet during a run (one progress line when it ends); stops the run on SIGINT/SIGTERM.
class Progress final : public RunObserver {
 public:
  bool on_iteration(const IterationRecord&) override { return !g_bench_interrupted.load(); }
  bool stop_requested() override { return g_bench_interrupted.load(); }
};

// Exact enough to keep distinct tolerances apart (2e-3 and 2.5e-3), short enough to read.
std::string tol_tag(double t) { return fmt::format("{:.6g}", t); }

nlohmann::json to_json(const BenchRow& r) {
  return {{"config", r.config},
          {"model", r.model},
          {"N", r.n_full},
          {"reducer", r.reducer},
          {"strategy", r.strategy},
          {"tolerance", r.tolerance},
          {"termination", r.termination},
          {"message", r.message},
          {"target_met", r.met},
          {"order", r.order},
          {"band_error", r.band_error},
          {"verified_band_error", r.verified_error},
          {"f_peak_hz", r.f_peak_hz},
          {"stable", r.stable},
          {"seconds", r.seconds},
          {"reducer_seconds", r.reducer_seconds},
          {"full_response_seconds", r.full_response_seconds},
          {"reducer_sparse_share", r.reducer_sparse_share},
          {"sparse_seconds", r.sparse_seconds},
          {"factorizations", r.factorizations},
          {"solves", r.solves},
          {"reducer_factorizations", r.reducer_factorizations},
          {"reducer_solves", r.reducer_solves},
          {"reducer_calls", r.reducer_calls},
          {"iterations", r.iterations},
          {"peak_memory_mb", r.peak_memory_mb}};
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += (c == '"') ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

std::string to_csv(const std::vector<BenchRow>& rows) {
  std::string out =
      "config,model,N,reducer,strategy,tolerance,termination,target_met,order,band_error,"
      "verified_band_error,f_peak_hz,stable,seconds,reducer_seconds,full_response_seconds,"
      "reducer_sparse_share,sparse_seconds,factorizations,solves,reducer_factorizations,reducer_solves,"
      "reducer_calls,iterations,peak_memory_mb,message\n";
  for (const BenchRow& r : rows) {
    out += fmt::format(
        "{},{},{},{},{},{:g},{},{},{},{:.6e},{:.6e},{:.6e},{},{:.4f},{:.4f},{:.4f},{:.3f},{:.4f},{},{},"
        "{},{},{},{},{:.1f},{}\n",
        csv_field(r.config), r.model, r.n_full, r.reducer, r.strategy, r.tolerance, r.termination,
        r.met ? 1 : 0, r.order, r.band_error, r.verified_error, r.f_peak_hz, r.stable ? 1 : 0,
        r.seconds, r.reducer_seconds, r.full_response_seconds, r.reducer_sparse_share,
        r.sparse_seconds, r.factorizations, r.solves, r.reducer_factorizations, r.reducer_solves, r.reducer_calls,
        r.iterations, r.peak_memory_mb, csv_field(r.message));
  }
  return out;
}

std::string to_markdown(const std::vector<BenchRow>& rows) {
  std::string out =
      "| model | N | reducer | strategy | tolerance | result | order | verified error | total s | "
      "reducer s | full response s | sparse s (all threads) | sparse share of reducer | "
      "factorisations (reducer) |\n"
      "|---|---:|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const BenchRow& r : rows) {
    const std::string result = r.met ? std::string("met") : r.termination;
    out += fmt::format("| {} | {} | {} | {} | {:g} | {} | {} | {:.2e} | {:.2f} | {:.3f} | {:.2f} | {:.2f} | {:.0f}% | {} ({}) |\n",
                       r.model, r.n_full, r.reducer, r.strategy, r.tolerance, result,
                       r.order > 0 ? std::to_string(r.order) : std::string("-"), r.verified_error,
                       r.seconds, r.reducer_seconds, r.full_response_seconds, r.sparse_seconds,
                       100.0 * r.reducer_sparse_share, r.factorizations, r.reducer_factorizations);
  }
  return out;
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
    std::vector<RunConfig> configs;
    for (const auto& path : options.configs) configs.push_back(load_run_config(path));
    std::signal(SIGINT, on_bench_signal);
    std::signal(SIGTERM, on_bench_signal);

    std::vector<BenchRow> rows;
    const std::filesystem::path out = std::filesystem::absolute(options.output_dir);
    std::size_t total = 0;
    total = configs.size() * std::max<std::size_t>(options.tolerances.size(), 1);
    std::size_t done = 0;
    std::set<std::string> used_names;
    bool all_met = true;
    const auto start = std::chrono::steady_clock::now();
    for (const RunConfig& base : configs) {
      std::vector<double> ladder = options.tolerances;
      if (ladder.empty()) ladder.push_back(base.tolerance);
      for (double tol : ladder) {
        if (g_bench_interrupted.load()) break;
        RunConfig config = base;
        config.tolerance = tol;
        if (options.time_limit_s > 0.0) config.time_limit_s = options.time_limit_s;
        // One directory per run: configs with the same file name in different folders, or a
        // tolerance given twice, get a numbered suffix instead of overwriting a run's outputs.
        std::string run_name = base.source.stem().string() + "_tol" + tol_tag(tol);
        for (int k = 2; used_names.count(run_name) > 0; ++k) {
          run_name = base.source.stem().string() + "_tol" + tol_tag(tol) + "_" + std::to_string(k);
        }
        used_names.insert(run_name);
        config.output_dir = out / "runs" / run_name;
        BenchRow row;
        row.config = base.source.string();
        row.model = base.model_dir.filename().string();
        row.reducer = base.reducer_name;
        row.strategy = base.strategy_name;
        row.tolerance = tol;
        ++done;
        fmt::print("[{}/{}] {} ({} / {}) tolerance {:g} ... ", done, total, row.model,
                   row.reducer, row.strategy, tol);
        std::fflush(stdout);
        try {
          Registry registry;
          load_plugins(registry, common, config.plugins);
          Progress progress;
          const RunSummary s = run_reduction(config, registry, &progress);
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
          const double sparse =
              s.reducer_counters.factorization_seconds + s.reducer_counters.solve_seconds;
          row.reducer_sparse_share = s.reducer_seconds > 0.0 ? sparse / s.reducer_seconds : 0.0;
          row.sparse_seconds = s.counters.factorization_seconds + s.counters.solve_seconds;
          row.factorizations = s.counters.factorizations;
          row.solves = s.counters.solves;
          row.reducer_factorizations = s.reducer_counters.factorizations;
          row.reducer_solves = s.reducer_counters.solves;
          row.reducer_calls = s.reducer_calls;
          row.iterations = s.iterations;
          row.peak_memory_mb = s.peak_memory_mb;
          fmt::print("{} order {} error {:.2e}, {:.2f} s (reducer {:.3f} s)\n",
                     row.met ? "met," : row.termination + ",", row.order, row.verified_error,
                     row.seconds, row.reducer_seconds);
        } catch (const std::exception& e) {
          // A failing run is a row of the table, not a missing one.
          row.termination = "error";
          row.message = e.what();
          fmt::print("error: {}\n", e.what());
        }
        all_met = all_met && row.met;
        rows.push_back(row);
        // Rewritten after every run, so an interrupted bench keeps what it measured.
        write_text_atomically(out / "bench.csv", to_csv(rows));
        nlohmann::json j = nlohmann::json::array();
        for (const BenchRow& r : rows) j.push_back(to_json(r));
        write_text_atomically(out / "bench.json", j.dump(2) + "\n");
        write_text_atomically(out / "bench.md", to_markdown(rows));
      }
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    fmt::print("\n{}\n{} runs in {:.1f} s; results in {}\n", to_markdown(rows), rows.size(),
               seconds, out.string());
    if (g_bench_interrupted.load()) return 130;
    return all_met ? 0 : 2;
  });
}

}  // namespace ecmor::app
