#include "commands.hpp"

#include <fmt/core.h>
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <iostream>

#include "ecmor/base/atomic_file.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/base/threads.hpp"
#include "ecmor/linalg/parallel.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/linalg/spectrum_summary.hpp"
#include "ecmor/model/model.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/run/config.hpp"
#include "ecmor/run/driver.hpp"
#include "ecmor/strategies/strategy.hpp"
#include "plot.hpp"
#include "signals.hpp"

namespace ecmor::app {
namespace {

// Prints the convergence table while the run goes on.
class TablePrinter final : public RunObserver {
 public:
  /// quiet: only the final result; silent: nothing (the ranks other than 0 under MPI).
  explicit TablePrinter(bool quiet, bool silent = false)
      : m_quiet(quiet || silent), m_silent(silent) {}

  void on_model_loaded(const RunConfig& config, const Model& model, double seconds) override {
    if (m_quiet) return;
    fmt::print("model    {} ({} model, N = {}, {} input(s), {} output(s); loaded in {:.2f} s)\n",
               config.model.path.string(), to_string(kind_of(model)), size_of(model),
               inputs_of(model), outputs_of(model), seconds);
    fmt::print("band     [{:g}, {:g}] Hz    target: relative {} error <= {:g}\n",
               config.band.f_min_hz, config.band.f_max_hz, to_string(config.norm),
               config.tolerance);
    if (config.portfolio.empty()) {
      fmt::print("reducer  {}    strategy {}    output {}\n", config.reducer_name,
                 config.strategy_name, config.output_dir.string());
    } else {
      std::vector<std::string> labels;
      for (const PortfolioMember& m : config.portfolio) labels.push_back(m.label());
      fmt::print("portfolio  {}    output {}\n", fmt::join(labels, ", "),
                 config.output_dir.string());
    }
    std::fflush(stdout);
  }

  // The memory plan comes before the first numeric factorisation, and the table after it.
  void on_memory_plan(const MemoryPlan& plan) override {
    if (m_quiet) return;
    fmt::print("memory   {}\n\n", plan.describe());
    fmt::print("{:>4}  {:<8} {:>5}  {:>10}  {:>11}  {:>4}  {:>8}  {:>6}  {:>7}  {}\n", "iter",
               "phase", "order", "band err", "f_peak Hz", "met", "time s", "facts", "solves",
               "note");
    std::fflush(stdout);
  }

  void on_member_started(std::size_t index, std::size_t count, const std::string& label) override {
    if (m_quiet) return;
    fmt::print("---- portfolio member {}/{}: {}\n", index + 1, count, label);
    std::fflush(stdout);
  }

  bool on_iteration(const IterationRecord& r) override {
    if (!m_quiet) {
      fmt::print("{:>4}  {:<8} {:>5}  {:>10.3e}  {:>11.4e}  {:>4}  {:>8.2f}  {:>6}  {:>7}  {}\n",
                 r.iteration, r.phase, r.order, r.band_error, r.f_peak_hz,
                 r.meets_tolerance ? "yes" : "no", r.seconds, r.counters.factorizations,
                 r.counters.solves, r.note);
      std::fflush(stdout);
    }
    return !stop_signalled();
  }

  bool stop_requested() override { return stop_signalled(); }

  // A sweep of full-model responses that takes a while gets a progress line (count, rate, time
  // left), rewritten in place on a terminal and printed every ~10 s otherwise.
  void on_sweep(const SweepProgress& p) override {
    if (m_quiet || p.seconds < 2.0) return;
    const bool tty = isatty(fileno(stdout)) != 0;
    const bool first = m_last_sweep_print < 0.0 || p.seconds < m_last_sweep_print;
    if (!tty && !first && p.done < p.total && p.seconds - m_last_sweep_print < 10.0) return;
    m_last_sweep_print = p.done < p.total ? p.seconds : -1.0;
    const double rate = p.done / p.seconds;
    const double left = rate > 0.0 ? static_cast<double>(p.total - p.done) / rate : 0.0;
    fmt::print("{}      full-model responses {}/{}  {:.2f}/s  {:.0f} s left{}", tty ? "\r" : "",
               p.done, p.total, rate, left, tty && p.done < p.total ? "" : "\n");
    std::fflush(stdout);
  }

  void on_finished(const RunSummary& s) override {
    if (m_silent) return;
    if (!m_quiet) fmt::print("\n");
    if (s.attempts.size() > 1) {
      for (const PortfolioAttempt& a : s.attempts) {
        fmt::print("  {} {:<28} {:<18} order {:>4}  band error {:>9.3e}  {:>7.2f} s\n",
                   a.selected ? "*" : " ", a.label(), a.termination, a.order, a.band_error,
                   a.seconds);
      }
    }
    fmt::print("{}: {}\n", to_string(s.termination), s.message);
    for (const std::string& w : s.warnings) fmt::print("warning: {}\n", w);
    if (s.has_model) {
      const std::string check =
          s.error_control.mode == "estimate"
              ? fmt::format("largest against the full model, at {:.4g} Hz of {} solved",
                            s.verified_f_peak_hz, s.error_control.checked_frequencies)
              : fmt::format("independent re-check {:.3e} at {:.4g} Hz", s.verified_band_error,
                            s.verified_f_peak_hz);
      fmt::print(
          "order {}  band error {:.3e} ({})  {}  "
          "{:.2f} s  {} factorisations  {} solves  peak {:.0f} MiB\n",
          s.order, s.band_error, check,
          s.stable ? s.stability.label : "NOT stable: " + s.stability.reason, s.seconds,
          s.counters.factorizations, s.counters.solves, s.peak_memory_mb);
      if (!s.error_control.mode_switch.empty())
        fmt::print("error control: {}\n", s.error_control.mode_switch);
      fmt::print("outputs in {}\n", s.output_dir.string());
    }
  }

 private:
  bool m_quiet;
  bool m_silent;
  double m_last_sweep_print = -1.0;  // seconds into the current sweep at the last line; < 0: none
};

// The plots of a finished run (plot.hpp). A reduction that worked is not failed by its pictures:
// a missing gnuplot is a one-line note, a failing gnuplot a warning; the exit code is the run's.
void plot_after_run(const std::filesystem::path& dir, bool quiet) {
  try {
    plot_run(dir, PlotFormat::Both);
    if (!quiet) fmt::print("plots: sigma, error, convergence (.png, .svg) in {}\n", dir.string());
  } catch (const GnuplotNotFound& e) {
    if (!quiet) fmt::print("note: {}\n", e.what());
  } catch (const Error& e) {
    fmt::print(stderr, "ecmor: warning: plots not rendered: {}\n", e.what());
  }
}

}  // namespace

int guarded(const std::function<int()>& body) {
  // Under MPI an error seen by one rank alone would leave the others waiting in a collective
  // solve: it is reported with the rank, and the whole job is ended.
  auto fail = [](const char* kind, const char* what) {
    if (process_count() > 1) {
      fmt::print(stderr, "ecmor: {} on rank {} of {}: {}\n", kind, process_rank(), process_count(),
                 what);
      std::fflush(stderr);
      abort_all_processes(1);
    }
    fmt::print(stderr, "ecmor: {}: {}\n", kind, what);
    return 1;
  };
  try {
    return body();
  } catch (const Error& e) {
    return fail("error", e.what());
  } catch (const std::exception& e) {
    return fail("internal error", e.what());
  }
}

// Loads default plugin directories (failures are warnings: one broken plugin must not stop the
// others) and explicitly requested plugins (failures are errors).
void load_plugins(Registry& registry, const CommonOptions& common,
                  const std::vector<std::filesystem::path>& from_config) {
  if (!common.no_default_plugins) {
    for (const auto& dir : default_plugin_directories()) {
      for (const std::string& problem : registry.load_directory(dir)) {
        fmt::print(stderr, "ecmor: warning: {}\n", problem);
      }
    }
  }
  std::vector<std::filesystem::path> explicit_paths = common.plugin_paths;
  explicit_paths.insert(explicit_paths.end(), from_config.begin(), from_config.end());
  for (const auto& path : explicit_paths) {
    if (std::filesystem::is_directory(path)) {
      for (const std::string& problem : registry.load_directory(path)) {
        throw PluginError(problem);
      }
    } else {
      registry.load_plugin(path);
    }
  }
}

int reduce(const std::filesystem::path& config_path, const CommonOptions& common) {
  // Under mpirun (read from the launcher's environment; MPI itself starts with the PETSc backend).
  const int rank = process_rank(), ranks = process_count();
  return guarded([&] {
    RunConfig config = load_run_config(config_path);
    if (!common.output_dir.empty())
      config.output_dir = std::filesystem::absolute(common.output_dir);
    if (ranks > 1 && config.solver.backend != "petsc") {
      // The embedded backend works in one process: rank 0 does the run, the others leave.
      if (rank != 0) return 0;
      fmt::print(stderr,
                 "ecmor: warning: {} MPI ranks, but backend '{}' runs in one process: rank 0 does "
                 "the whole run and the other ranks exit (backend: {{name: petsc}} distributes the "
                 "factorisations over the ranks)\n",
                 ranks, config.solver.backend);
    }
    Registry registry;
    load_plugins(registry, common, config.plugins);
    install_stop_signals();
    TablePrinter printer(common.quiet, /*silent=*/rank != 0);
    const RunSummary summary = run_reduction(config, registry, &printer);
    if (rank == 0 && summary.has_model && !common.no_plot)
      plot_after_run(summary.output_dir, common.quiet);
    // 130 only for a signal; a run stopped by its time limit missed its target like any budget.
    if (summary.termination == Termination::Interrupted && stop_signalled()) return 130;
    return summary.exit_code();
  });
}

int plot(const std::filesystem::path& run_dir, const std::string& format) {
  return guarded([&] {
    const PlotFormat f = parse_plot_format(format);
    // A missing gnuplot is an error here: rendering is all this command does.
    for (const auto& file : plot_run(run_dir, f)) fmt::print("{}\n", file.string());
    return 0;
  });
}

namespace {

void print_parameters(const std::vector<ParameterDoc>& parameters) {
  for (const auto& p : parameters) {
    fmt::print("    {:<22} {:<8} default {:<10} {}\n", p.name, p.type, p.default_value,
               p.description);
  }
}

}  // namespace

int plugins(const CommonOptions& common) {
  return guarded([&] {
    Registry registry;
    load_plugins(registry, common, {});
    const auto entries = registry.entries();
    if (entries.empty()) {
      fmt::print("no reducers loaded (searched:");
      for (const auto& d : default_plugin_directories()) fmt::print(" {}", d.string());
      fmt::print(")\n");
      return 1;
    }
    for (const auto& e : entries) {
      fmt::print("{}  (version {}; {}{}{})\n  {}\n  library: {}\n", e.info.name, e.info.version,
                 e.info.second_order ? "second-order" : "",
                 e.info.second_order && e.info.descriptor ? " + " : "",
                 e.info.descriptor ? "descriptor" : "", e.info.description,
                 e.library.empty() ? "(built in)" : e.library.string());
      print_parameters(e.info.parameters);
      fmt::print("\n");
    }
    // The strategies are built in; their options come from the same kind of specs.
    for (const auto& name : run_strategy_names()) {
      fmt::print("strategy {}  (built in)\n", name);
      print_parameters(run_strategy_options(name));
      fmt::print("\n");
    }
    return 0;
  });
}

namespace {

/// The modes spectrum_summary() found, one line each.
void print_spectrum(const SpectrumSummary& s) {
  if (s.undamped) {
    fmt::print("{}\n", s.rigid_body);
    fmt::print("lowest {} undamped eigenfrequencies [Hz]:\n", s.modes.size());
  } else {
    fmt::print("{} eigenvalues of (A, E) nearest 0: |lambda|/2pi [Hz], damping ratio:\n",
               s.modes.size());
  }
  for (std::size_t i = 0; i < s.modes.size(); ++i) {
    const SpectrumMode& m = s.modes[i];
    if (m.damping_ratio) {
      fmt::print("  {:>4}  {:.6e}  {:+.3e}\n", i + 1, m.frequency_hz, *m.damping_ratio);
    } else {
      fmt::print("  {:>4}  {:.6e}{}\n", i + 1, m.frequency_hz,
                 m.rigid ? "  (rigid-body mode)" : "");
    }
  }
}

// The thread budget and the BLAS (threads.hpp): what a run on this machine will use.
void print_threads() {
  const ThreadBudget t = thread_budget();
  const BlasInfo blas = blas_info();
  fmt::print("threads: at most {} of {} core(s), {}; BLAS: {} ({} threading)\n", t.limit, t.cores,
             t.adaptive ? "fewer while other processes keep cores busy (ECMOR_THREADS=n fixes n)"
                        : "fixed by " + t.source,
             blas.name, blas.threading);
}

}  // namespace

int info(const std::filesystem::path& model_path, int eigenfrequencies, const CommonOptions&) {
  return guarded([&] {
    print_threads();
    if (model_path.empty()) return 0;
    const Model model = load_model(model_path);
    const ModelSummary s = summarize(model);
    fmt::print("{}: {} model, N = {}, {} input(s), {} output(s){}\n", model_path.string(),
               to_string(s.kind), s.size, s.inputs, s.outputs,
               s.velocity_output ? ", velocity output (Cv)" : "");
    fmt::print("  {:<4} {:>12} {:>12}  {:>12}  {}\n", "", "size", "nnz", "asymmetry",
               "definiteness");
    for (const auto& m : s.matrices) {
      fmt::print("  {:<4} {:>12} {:>12}  {:>12.2e}  {}\n", m.name,
                 fmt::format("{}x{}", m.rows, m.cols), m.nnz, m.relative_asymmetry, m.definiteness);
    }
    if (s.second_order_size > 0) {
      // Worth knowing before choosing a reducer: such a model can be reduced with its structure
      // (and stability) preserved, see the krylov plugin's `structure` key.
      fmt::print(
          "  second-order structure: x = [q; q'], M q'' + D q' + K q = B u with n = {}; "
          "M, D, K {}\n",
          s.second_order_size,
          s.second_order_symmetric
              ? "symmetric (krylov reduces it as second order: structure: auto)"
              : "not all symmetric (krylov keeps the first-order path)");
    }
    if (eigenfrequencies <= 0) return 0;
    auto solver = make_shifted_solver(model);
    try {
      print_spectrum(spectrum_summary(model, *solver, eigenfrequencies));
    } catch (const Error& e) {
      fmt::print("eigenfrequencies not computed: {}\n", e.what());
    }
    return 0;
  });
}

}  // namespace ecmor::app
