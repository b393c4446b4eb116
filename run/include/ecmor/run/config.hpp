#pragma once
/// \file config.hpp
/// The YAML run configuration, validated: unknown keys are errors that suggest the nearest valid
/// key; wrong types and ranges name the key and its line. Example:
///
///   model:    {dir: models/triplechain_saak09_n451}   # or {file: m.mat}
///   band:     {f_min_hz: 1.0e-5, f_max_hz: 10.0}
///   target:   {tolerance: 1.0e-3, norm: spectral}        # spectral (Eq. 22) | frobenius (Eq. 23)
///   reducer:  {name: modal, static_correction: true}     # plus reducer-specific parameters
///   strategy: {name: grow_order, max_order: 200}         # plus strategy-specific parameters
///   error:    {grid_points: 200, refine_peaks: 5}        # optional: the error estimator
///   solver:   {threads: 0}                               # optional
///   output:   {dir: out/tc451, format: mtx}            # format: mtx (default) | mat | both
///   plugins:  [path/to/libmy_plugin.so, path/to/dir]     # optional: extra plugins
///   check:    {max_order: 48, max_seconds: 600}          # optional: budgets for `ecmor check`
///   compress: true                                       # optional; false: the model as accepted
///
/// A portfolio run tries several reducer/strategy pairs on the same model, one after another, and
/// keeps the smallest passing model (no top-level `reducer` section then). Without `members` it
/// tries the bundled reducers suited to the model (run/src/portfolio.hpp, default_portfolio):
///
///   strategy:
///     name: portfolio
///     prune: true                                        # optional (default true)
///     members:
///       - reducer:  {name: modal}
///       - reducer:  {name: krylov, points: [0.0]}
///         strategy: {name: greedy_points, max_order: 80}  # default: grow_order
///       - reducer:  {name: modal}
///         strategy: {name: mixed_basis}
///         fallback: true                                 # only if no member before met it
///
/// Relative paths (model.dir, model.file, output.dir, plugins) are resolved against the current
/// working directory, like paths given on a command line.

#include <filesystem>
#include <string>
#include <vector>

#include "ecmor/base/parameters.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/measures/band_error.hpp"
#include "ecmor/model/model_io.hpp"

namespace ecmor {

/// One reducer/strategy pair of a portfolio run (strategy.members[k]).
struct PortfolioMember {
  std::string reducer_name;
  ParameterMap reducer_params{"reducer"};
  std::string strategy_name = "grow_order";
  ParameterMap strategy_params{"strategy"};
  /// Runs only when no member before it met the target (YAML `fallback: true`): a slower method
  /// kept for the models the others cannot reduce. Otherwise its attempt is "not_needed".
  bool fallback = false;
  /// "reducer/strategy", for tables and messages.
  std::string label() const { return reducer_name + "/" + strategy_name; }
};

struct RunConfig {
  std::filesystem::path source;  ///< the YAML file
  /// model.dir (a model directory) or model.file with model.variables (a .mat file).
  ModelSource model;
  Band band;
  double tolerance = 1e-3;  ///< on sup_f of the relative error, (0, 1e3]
  ErrorNorm norm = ErrorNorm::Spectral;
  std::string reducer_name;
  ParameterMap reducer_params{"reducer"};
  std::string strategy_name = "grow_order";
  ParameterMap strategy_params{"strategy"};
  /// Wall-clock budget of the run in seconds (YAML strategy.time_limit_s; 0: none). When it is
  /// used up the strategy is asked to stop, as for an interrupt: the run ends "interrupted" with
  /// the best model so far, and the message says that the time limit ended it.
  double time_limit_s = 0.0;
  BandErrorOptions error;   ///< norm is copied from target.norm
  Index verify_factor = 4;  ///< independent re-check grid is this many times denser
  /// The reported model's error H-infinity norm is computed by the dense level-set method (all
  /// frequencies, certified) when the full model has at most this many first-order states, else
  /// sampled on the band (YAML error.hinf_dense_states; 0: always sampled). Each level-set
  /// iteration solves a Hamiltonian eigenproblem of size 2 (states + order): about 5 s at 500.
  Index hinf_dense_states = 250;
  /// The full model's own stability (stability.hpp) is decided from its dense eigenvalues when it
  /// has at most this many first-order states (YAML error.stability_dense_states; 0: never dense),
  /// else from the inertia of K and D (second order) or not at all. About 1 s at 1000.
  Index stability_dense_states = 1000;
  SolverOptions solver;
  int threads = 0;  ///< the run's thread count; 0: the process's budget (threads.hpp)
  std::filesystem::path output_dir;
  OutputFormat output_format = OutputFormat::Mtx;  ///< output.format: mtx (default), mat, both
  std::vector<std::filesystem::path> plugins;
  /// `strategy: {name: portfolio, members: [...]}`: reducer_name and strategy_name are then both
  /// "portfolio" and the members carry the real ones. Empty for a portfolio without `members`
  /// until the driver, knowing the model, fills in default_portfolio().
  std::vector<PortfolioMember> portfolio;
  bool is_portfolio() const { return strategy_name == "portfolio"; }
  /// Portfolio only: stop a grow_order member once its order reaches the smallest order that met
  /// the target so far without meeting it (it can then no longer win).
  bool portfolio_prune = true;
  /// Portfolio runs: once a member has met the target, each later member may make at most this
  /// many times its full-model factorisations (`race`; 0: no limit). See
  /// docs/strategies.md#portfolio.
  double portfolio_race = 3.0;
  /// After a run meets its target, search the accepted model for the smallest model inside it
  /// that still meets it (YAML `compress: true | false`, default true; driver.hpp).
  bool compress = true;
  /// Regression budgets checked by `ecmor check` (YAML `check: {max_order, max_seconds}`; 0: none).
  /// `ecmor reduce` ignores them.
  Index check_max_order = 0;
  double check_max_seconds = 0.0;
};

/// Parses and validates a run configuration.
/// \throws ConfigError "run.yaml:4: unknown key 'tolerence' in 'target' (did you mean
/// 'tolerance'?)",
///         "run.yaml:3: band.f_min_hz = -1: must be > 0", missing required keys, YAML syntax errors
///         with their line.
RunConfig load_run_config(const std::filesystem::path& path);

/// What a configuration must hold besides band, target and the reducer/strategy sections.
struct ConfigRequirements {
  /// The model section is required. False: the caller holds the model in memory (the Python
  /// module's ecmor.reduce(model, ...)), and a model section is an error.
  bool model = true;
  /// The output section (output.dir) is required. False: it is optional; without output.dir
  /// the run writes nothing (RunConfig::output_dir empty).
  bool output = true;
  /// Messages cite "name:line". False for text generated from another form (a Python dict),
  /// whose lines mean nothing to the user: messages cite `name` alone.
  bool lines = true;
};

/// Same from a string; `name` is used in messages.
RunConfig parse_run_config(const std::string& yaml, const std::string& name,
                           const ConfigRequirements& requirements = {});

/// The names strategy.name takes: every strategy (strategy_names()) and "portfolio", last.
std::vector<std::string> run_strategy_names();

/// The documented options of strategy.name `name`: a strategy's (strategy_parameters()) or the
/// portfolio's (portfolio_options()). \throws ConfigError for unknown names.
std::vector<ParameterDoc> run_strategy_options(const std::string& name);

/// The documented options of the portfolio strategy's own keys (`members`, `prune`, `race`;
/// `name` and `time_limit_s` are the strategy section's, section_options("strategy")), from the
/// option specs the reader uses: what `ecmor plugins` and docs/strategies.md print.
std::vector<ParameterDoc> portfolio_options();

/// The configuration's sections, each read through option specs, in the order of the file and of
/// docs/user-guide.md: model, band, target, reducer, strategy, error, solver, backend, output,
/// check. The reducer and strategy sections list their own keys (name, time_limit_s); their
/// other keys are the reducer's or strategy's options, documented by the plugin.
std::vector<std::string> option_section_names();

/// The documented keys of a section (option_section_names()), from the option specs the reader
/// uses: what docs/user-guide.md prints. \throws std::invalid_argument for any other name.
std::vector<ParameterDoc> section_options(const std::string& section);

/// The documented keys of the top level that are not sections (plugins, compress).
std::vector<ParameterDoc> top_level_options();

}  // namespace ecmor
