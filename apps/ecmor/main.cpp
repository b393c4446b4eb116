// ecmor: adaptive, error-controlled model order reduction. Parses arguments and dispatches; no
// numerics here.
#include <CLI/CLI.hpp>
#include <cstdlib>
#include <iostream>
#include <vector>

#include "commands.hpp"
#include "ecmor/version.hpp"

namespace {

using ecmor::app::CommonOptions;
namespace app = ecmor::app;

// The options of every subcommand, filled in by CLI11; only the chosen subcommand's are used.
struct Arguments {
  CommonOptions common;
  std::filesystem::path config;   // reduce
  std::filesystem::path run_dir;  // plot
  std::string plot_format = "both";
  ecmor::app::BenchOptions bench;
  ecmor::app::CheckOptions check;
  std::filesystem::path model_path;  // info
  int eigenfrequencies = 10;
  ecmor::app::ConformOptions conform;
  ecmor::app::SimulateOptions simulate;
  std::filesystem::path import_config;
  ecmor::app::ExportBodyOptions export_body;
};

// The options of the subcommands that load plugins, after their own.
void add_common(CLI::App& sub, CommonOptions& common) {
  sub.add_option("--plugin", common.plugin_paths, "extra plugin library or directory (repeatable)");
  sub.add_flag("--no-default-plugins", common.no_default_plugins,
               "do not load plugins from $ECMOR_PLUGIN_PATH and <prefix>/lib/ecmor/plugins");
  sub.add_flag("-q,--quiet", common.quiet, "print only the final summary line");
}

// Each subcommand's own options, in the order of its --help.

void reduce_options(CLI::App& reduce, Arguments& a) {
  reduce.add_option("config", a.config, "YAML run configuration")->required();
  reduce.add_option("-o,--output", a.common.output_dir, "output directory (overrides output.dir)");
  reduce.add_flag("--no-plot", a.common.no_plot,
                  "do not render the plots (sigma, error, convergence; needs gnuplot, skipped "
                  "with a note if it is missing)");
}

void plot_options(CLI::App& plot, Arguments& a) {
  plot.add_option("run_dir", a.run_dir, "output directory of an `ecmor reduce` run")->required();
  plot.add_option("--format", a.plot_format, "png, svg or both (default both)");
}

void no_options(CLI::App& /*sub*/, Arguments& /*a*/) {}

void bench_options(CLI::App& bench, Arguments& a) {
  bench.add_option("configs", a.bench.configs, "YAML run configurations")->required();
  bench
      .add_option("-t,--tolerances", a.bench.tolerances,
                  "tolerance ladder, e.g. 1e-2,1e-3,1e-4 (default: each config's own)")
      ->delimiter(',');
  bench.add_flag("--portfolio-as-one", a.bench.portfolio_as_one,
                 "bench a portfolio config as one run (default: each member on its own)");
  bench.add_flag("--all-reducers", a.bench.all_reducers,
                 "run every loaded reducer that accepts the model (default parameters, "
                 "grow_order) instead of the config's reducer");
  bench.add_option("-o,--output", a.bench.output_dir, "output directory (default out/bench)");
  bench
      .add_option("--time-limit", a.bench.time_limit_s,
                  "wall-clock limit of each run in seconds (a run that reaches it is "
                  "reported as interrupted, with its best model; default: the YAML's "
                  "strategy.time_limit_s, else none)")
      ->check(CLI::PositiveNumber);
}

void check_options(CLI::App& check, Arguments& a) {
  check
      .add_option("inputs", a.check.inputs,
                  "YAML configurations or directories of them (*.yaml, not recursive)")
      ->required();
  check.add_option("-o,--output", a.check.output_dir,
                   "output directory; each config's run goes to DIR/<config name> (default "
                   "out/check)");
}

void info_options(CLI::App& info, Arguments& a) {
  info.add_option("model", a.model_path,
                  "directory with M,D,K,B,C[,Cv].mtx or E,A,B,C.mtx, or a .mat file with "
                  "variables of those names");
  info.add_option("--eigenfrequencies", a.eigenfrequencies,
                  "how many of the lowest eigenfrequencies to compute (0: none)")
      ->check(CLI::Range(0, 1000));
}

void conform_options(CLI::App& conform, Arguments& a) {
  conform.add_option("--reducer", a.conform.reducer, "the reducer's name")->required();
  conform.add_option("--set", a.conform.settings,
                     "a reducer parameter key=value (repeatable), as in the YAML reducer section");
  conform
      .add_option("--orders", a.conform.orders,
                  "ascending orders of the dimension/growth checks (default 2,4,8)")
      ->delimiter(',');
  conform
      .add_option("--tolerance", a.conform.tolerance,
                  "relative agreement of transfer functions (default 1e-8)")
      ->check(CLI::PositiveNumber);
  conform.add_option(
      "--model", a.conform.model_dir,
      "run on this model (directory or .mat file) instead of the built-in models (needs "
      "--band)");
  conform.add_option("--band", a.conform.band_hz, "F_MIN,F_MAX in Hz for --model")->delimiter(',');
  conform.add_flag("--with-builtin", a.conform.with_builtin,
                   "with --model: run the built-in models too");
  conform.add_option("--json", a.conform.json, "also write the report to this JSON file");
}

void simulate_options(CLI::App& simulate, Arguments& a) {
  simulate.add_option("run_dir", a.simulate.run_dir, "output directory of `ecmor reduce`")
      ->required();
  simulate.add_option("--input", a.simulate.input, "step | impulse | chirp (default step)");
  simulate.add_option("--input-index", a.simulate.input_index,
                      "0-based input (column of B) driven; default -1: all inputs at once");
  simulate.add_option("--amplitude", a.simulate.amplitude, "input amplitude (default 1)");
  simulate.add_option("--t-end", a.simulate.t_end,
                      "end time [s] (default: 5 time constants of the slowest decaying term of "
                      "the reduced model's response that matters, at most 5 periods of the "
                      "band's f_min; a chirp, or a response that does not settle: 5 periods of "
                      "f_min, or of the chirp's lowest frequency if lower)");
  simulate.add_option("--steps", a.simulate.steps,
                      "time steps (default: 20 per period of the fastest term that matters, at "
                      "most the band's f_max, or of the chirp's highest frequency if higher; at "
                      "least 200, at most 200000)");
  simulate.add_option("--time-axis", a.simulate.time_axis,
                      "auto | linear | log: time axis of the plot (auto: log when the dynamics "
                      "span more than three decades)");
  simulate.add_option("--scheme", a.simulate.scheme,
                      "newmark (average acceleration; trapezoidal rule for descriptor models; "
                      "default) | generalized-alpha");
  simulate.add_option("--rho-inf", a.simulate.rho_inf,
                      "generalized-alpha spectral radius at infinity in [0, 1] (default 1)");
  simulate
      .add_option("--chirp-hz", a.simulate.chirp_hz,
                  "chirp start and end frequency F0,F1 in Hz, linear sweep (default: the "
                  "band's f_min,f_max)")
      ->delimiter(',');
  // No plugins are involved: only --quiet of the common options applies.
  simulate.add_flag("-q,--quiet", a.common.quiet, "print only the output-error line");
  simulate.add_flag("--no-plot", a.common.no_plot,
                    "do not render time_response.png/.svg (needs gnuplot)");
}

// `import calculix`: CalculiX is the only importer, so `import` (which requires one nested
// subcommand) runs it.
void import_options(CLI::App& import_cmd, Arguments& a) {
  import_cmd.require_subcommand(1);
  auto* import_ccx = import_cmd.add_subcommand(
      "calculix",
      "from a CalculiX input deck: runs ccx for K and M, B and C on node sets, "
      "Rayleigh D (docs/import-calculix.md)");
  import_ccx->add_option("config", a.import_config, "YAML import configuration")->required();
  import_ccx->add_option("-o,--output", a.common.output_dir,
                         "model directory to write (overrides output.dir)");
  import_ccx->add_flag("-q,--quiet", a.common.quiet, "print only the summary line");
}

// export-body (docs/multibody.md)
void export_body_options(CLI::App& export_body, Arguments& a) {
  export_body.add_option("run_dir", a.export_body.run_dir, "output directory of `ecmor reduce`")
      ->required();
  export_body.add_option("-o,--output", a.export_body.output,
                         "SID file (default RUN_DIR/body.SID_FEM; the JSON goes next to it)");
  export_body.add_option("--mass-model", a.export_body.mass_model_dir,
                         "model directory of the same mesh without boundary conditions: the "
                         "mass of constrained DOFs for m, c, J");
  export_body.add_flag("--all-nodes", a.export_body.all_nodes,
                       "write every node to the frame (default: nodes of the inputs/outputs)");
  export_body.add_flag("-q,--quiet", a.common.quiet, "print only the summary line");
}

// A subcommand: its name and help line; whether it loads plugins (then it takes the common
// options after its own); its own options; and what it runs.
struct Command {
  const char* name;
  const char* help;
  bool loads_plugins;
  void (*add_options)(CLI::App& sub, Arguments& a);
  int (*run)(const Arguments& a);
};

// In the order of `ecmor --help`.
const Command kCommands[] = {
    {"reduce",
     "reduce a model as configured in a YAML file (exit 0: target met, 2: target "
     "missed but a model was written, 1: error, 130: interrupted)",
     true, reduce_options, [](const Arguments& a) { return app::reduce(a.config, a.common); }},
    {"plot", "render sigma, error and convergence plots of a finished run (needs gnuplot)", false,
     plot_options, [](const Arguments& a) { return app::plot(a.run_dir, a.plot_format); }},
    {"plugins", "list the loaded reducers and the strategies, with their parameters", true,
     no_options, [](const Arguments& a) { return app::plugins(a.common); }},
    {"bench",
     "run configurations over a ladder of tolerances and tabulate order reached, "
     "errors, times and counters (bench.csv, bench.json, bench.md)",
     true, bench_options, [](const Arguments& a) { return app::bench(a.bench, a.common); }},
    {"check",
     "run configurations as regression tests of their tolerance targets (and of their "
     "optional check: budgets); pass/fail table, exit 1 on any failure",
     true, check_options, [](const Arguments& a) { return app::check(a.check, a.common); }},
    {"info",
     "describe a model (directory or .mat file): sizes, nnz, symmetry, definiteness, "
     "lowest eigenfrequencies; and the threads and BLAS ecmor runs on (alone without a model)",
     true, info_options,
     [](const Arguments& a) { return app::info(a.model_path, a.eigenfrequencies, a.common); }},
    {"conform",
     "run the reducer conformance suite on one reducer (dimensions, projection, "
     "full order, determinism, growth, band, points, bad input); exit 1 on a failure",
     true, conform_options, [](const Arguments& a) { return app::conform(a.conform, a.common); }},
    {"simulate",
     "simulate the full and the reduced model of a reduce run (RUN_DIR) for a step, "
     "impulse or chirp input; writes time_response.csv and time_error.json (output "
     "error y - yr, L2 and max norms)",
     false, simulate_options,
     [](const Arguments& a) { return app::simulate(a.simulate, a.common); }},
    {"import",
     "build a model directory (M, D, K, B, C .mtx, nodes.csv, dofs.csv) from another "
     "program's model",
     false, import_options,
     [](const Arguments& a) { return app::import_calculix(a.import_config, a.common); }},
    {"export-body",
     "write the reduced elastic body of a reduce run (RUN_DIR) for multibody "
     "tools: mass invariants as a SID file and JSON (needs nodes.csv, dofs.csv)",
     false, export_body_options,
     [](const Arguments& a) { return app::export_body(a.export_body, a.common); }},
};

}  // namespace

int main(int argc, char** argv) {
  // Idle OpenMP threads sleep instead of spinning: between the parallel band-response batches the
  // driver does serial work, and spinning workers would steal its core (measured: 2 threads were
  // 2.4x slower than 1 on iss_so). Must be set before the OpenMP runtime starts; a user's setting
  // wins.
  setenv("OMP_WAIT_POLICY", "PASSIVE", /*overwrite=*/0);
  CLI::App cli{"ecmor " ECMOR_VERSION_STRING
               ": error-controlled model order reduction of large sparse second-order and "
               "descriptor models"};
  cli.require_subcommand(1);
  cli.set_version_flag("--version", std::string("ecmor ") + ECMOR_VERSION_STRING);

  Arguments a;
  for (const Command& c : kCommands) {
    CLI::App& sub = *cli.add_subcommand(c.name, c.help);
    c.add_options(sub, a);
    if (c.loads_plugins) add_common(sub, a.common);
  }
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e) == 0 ? 0 : 1;
  }
  for (const Command& c : kCommands) {
    if (cli.got_subcommand(c.name)) return c.run(a);
  }
  return 1;
}
