#pragma once
/// \file commands.hpp
/// The subcommands of the `ecmor` command line. Each returns the process exit code.

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "ecmor/base/types.hpp"

namespace ecmor {
class Registry;
}

namespace ecmor::app {

struct CommonOptions {
  std::vector<std::filesystem::path> plugin_paths;  ///< --plugin (files or directories)
  bool no_default_plugins = false;                  ///< --no-default-plugins
  bool quiet = false;                               ///< --quiet
  std::filesystem::path output_dir;                 ///< --output: overrides output.dir
  bool no_plot = false;                             ///< --no-plot: skip the plots
};

/// Runs a command body; an ecmor::Error (or any exception) becomes a message on stderr and exit 1.
int guarded(const std::function<int()>& body);

/// Loads the plugins of the default directories (failures are warnings), then those given by
/// --plugin and the config's `plugins:` key (failures throw PluginError).
void load_plugins(Registry& registry, const CommonOptions& common,
                  const std::vector<std::filesystem::path>& from_config);

/// `ecmor reduce CONFIG`: 0 target met, 2 usable model but target missed, 1 error, 130 interrupted.
int reduce(const std::filesystem::path& config, const CommonOptions& common);
/// `ecmor plot RUN_DIR [--format png|svg|both]`: sigma, error and convergence plots of a finished
/// run (plot.hpp). 0 when rendered; 1 when a file is missing, the format is unknown or gnuplot is
/// missing or fails.
int plot(const std::filesystem::path& run_dir, const std::string& format);
/// `ecmor plugins`: list the registered reducers with library, version and parameters.
int plugins(const CommonOptions& common);
/// Options of `ecmor bench`.
struct BenchOptions {
  std::vector<std::filesystem::path> configs;
  std::vector<double> tolerances;  ///< empty: each config's own tolerance
  std::filesystem::path output_dir = "out/bench";
  double time_limit_s = 0.0;  ///< > 0: wall-clock limit of every run (overrides YAML)
  /// Run a portfolio config as one run (default: each member on its own, one series each).
  bool portfolio_as_one = false;
  /// Replace each config's reducer by every loaded reducer that accepts the model's kind, with
  /// default parameters (and grow_order, keeping the config's grow_order parameters).
  bool all_reducers = false;
};
/// `ecmor bench CONFIG...`: runs every config at every tolerance of the ladder, records order,
/// errors, times and counters per run; writes bench.csv, bench.json and bench.md (a table).
/// 0 when every run met its target, 2 when some did not, 1 on an error before the runs.
int bench(const BenchOptions& options, const CommonOptions& common);
/// Options of `ecmor check`.
struct CheckOptions {
  std::vector<std::filesystem::path> inputs;  ///< config files or directories of *.yaml
  std::filesystem::path output_dir = "out/check";
};
/// `ecmor check CONFIG_OR_DIR...`: runs each config and checks its target (met, independent
/// re-check within tolerance, stable) and its `check:` budgets; prints a pass/fail table and writes
/// check.json and check.md. 0 when all pass, 1 when any fails or on an error, 130 interrupted.
int check(const CheckOptions& options, const CommonOptions& common);
/// `ecmor info MODEL`: sizes, nnz, symmetry, definiteness, lowest eigenfrequencies of a model
/// directory or .mat file.
int info(const std::filesystem::path& model_path, int eigenfrequencies,
         const CommonOptions& common);

/// Options of `ecmor simulate` (0 / empty: the default derived from the run's band).
struct SimulateOptions {
  static constexpr long kMaxDefaultSteps = 200000;  ///< cap of the default --steps
  std::filesystem::path run_dir;
  std::string input = "step";  ///< step | impulse | chirp
  long input_index = -1;       ///< 0-based column of B; -1: all inputs at once
  double amplitude = 1.0;
  double t_end = 0.0;              ///< 0: from the reduced model's poles (suggest_time_span)
  long steps = 0;                  ///< 0: 20 per period of the fastest relevant dynamics (capped)
  std::string time_axis = "auto";  ///< auto | linear | log (auto: log over > 3 decades)
  std::string scheme = "newmark";  ///< newmark | generalized-alpha
  double rho_inf = 1.0;
  std::vector<double> chirp_hz;  ///< empty: the band [f_min, f_max]
};
/// `ecmor simulate RUN_DIR`: time-domain outputs of the full and the reduced model of a run and
/// the output error y - yr (time_response.csv, time_error.json). 0 on success, 1 on an error.
int simulate(const SimulateOptions& options, const CommonOptions& common);

/// `ecmor import calculix CONFIG [-o DIR]`: a model directory from a CalculiX deck (calculix.hpp).
/// 0 when written, 1 on an error.
int import_calculix(const std::filesystem::path& config, const CommonOptions& common);

/// Options of `ecmor export-body` (docs/multibody.md).
struct ExportBodyOptions {
  std::filesystem::path run_dir;         ///< output directory of `ecmor reduce`
  std::filesystem::path output;          ///< SID file; empty: RUN_DIR/body.SID_FEM
  std::filesystem::path mass_model_dir;  ///< the mesh without boundary conditions (optional)
  bool all_nodes = false;                ///< frame: every node (default: input/output nodes)
};
/// `ecmor export-body RUN_DIR`: the reduced elastic body (mass invariants, seed Eq. 5) as a SID
/// file and JSON. 0 when written, 1 on an error.
int export_body(const ExportBodyOptions& options, const CommonOptions& common);

/// Options of `ecmor conform`.
struct ConformOptions {
  std::string reducer;                ///< the reducer's YAML name
  std::vector<std::string> settings;  ///< --set key=value: the reducer's parameters
  std::vector<Index> orders;          ///< empty: the suite's default (2, 4, 8)
  double tolerance = 0.0;             ///< 0: the suite's default (1e-8)
  std::filesystem::path model_dir;    ///< a model of the user's, instead of the built-in ones
  std::vector<double> band_hz;        ///< its band F_MIN,F_MAX (Hz), required with model_dir
  bool with_builtin = false;          ///< run the built-in models as well as model_dir
  std::filesystem::path json;         ///< also write the report as JSON
};
/// `ecmor conform --reducer NAME`: the conformance suite (conformance.hpp) on one reducer; prints
/// one row per check. 0 when no check failed, 1 otherwise or on an error.
int conform(const ConformOptions& options, const CommonOptions& common);

}  // namespace ecmor::app
