// The YAML run configuration: a full round trip, defaults, and for every way to get it wrong a
// ConfigError naming the file, the line and the key.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "common/test_support.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/run/config.hpp"

namespace fs = std::filesystem;
using namespace ecmor;

namespace {

template <class F>
std::string config_error(F&& f) {
  return test::message_of<ConfigError>(std::forward<F>(f));
}

std::string parse_error(const std::string& yaml) {
  return config_error([&] { parse_run_config(yaml, "run.yaml"); });
}

// A valid configuration, one key per line so that line numbers in messages are easy to predict.
// Tests replace one line to break exactly one rule.
const std::string kMinimal =
    "model:\n"               // 1
    "  dir: models/lf10\n"   // 2
    "band:\n"                // 3
    "  f_min_hz: 0.1\n"      // 4
    "  f_max_hz: 100\n"      // 5
    "target:\n"              // 6
    "  tolerance: 1.0e-3\n"  // 7
    "reducer:\n"             // 8
    "  name: modal\n"        // 9
    "output:\n"              // 10
    "  dir: out/lf10\n";     // 11

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const auto pos = text.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  if (pos != std::string::npos) text.replace(pos, from.size(), to);
  return text;
}

}  // namespace

TEST(RunConfig, FullConfigRoundTrip) {
  const std::string yaml =
      "# a complete run\n"
      "model: {dir: models/triplechain_saak09_n451}\n"
      "band: {f_min_hz: 1.0e-5, f_max_hz: 10}\n"
      "target: {tolerance: 2.5e-4, norm: frobenius}\n"
      "reducer:\n"
      "  name: krylov\n"
      "  two_sided: true\n"
      "  batch: 4\n"
      "  shift: -1.5\n"
      "  method: arnoldi\n"
      "  points_hz: [0.1, 1, 2.5e1]\n"
      "  outputs: [y1, y2]\n"
      "  tag: \"123\"\n"
      "  empty: []\n"
      "strategy: {name: greedy, max_order: 80, growth: 1.5}\n"
      "error:\n"
      "  grid_points: 300\n"
      "  pole_samples: no\n"
      "  max_pole_samples: 50\n"
      "  refine_peaks: 7\n"
      "  refine_evaluations: 12\n"
      "  zero_threshold: 1.0e-12\n"
      "  verify_factor: 8\n"
      "solver: {threads: 2, use_cholesky: false, symmetry_tol: 1.0e-10, singular_rcond: 1e-15}\n"
      "output: {dir: /tmp/ecmor_out}\n"
      "plugins: [plugins/libx.so, /opt/ecmor/plugins]\n";
  const RunConfig c = parse_run_config(yaml, "full.yaml");
  const fs::path cwd = fs::current_path();
  EXPECT_EQ(c.model.path, (cwd / "models/triplechain_saak09_n451").lexically_normal());
  EXPECT_TRUE(c.model.path.is_absolute());
  EXPECT_EQ(c.band.f_min_hz, 1.0e-5);
  EXPECT_EQ(c.band.f_max_hz, 10.0);
  EXPECT_EQ(c.tolerance, 2.5e-4);
  EXPECT_EQ(c.norm, ErrorNorm::Frobenius);
  EXPECT_EQ(c.error.norm, ErrorNorm::Frobenius);  // copied from target.norm

  EXPECT_EQ(c.reducer_name, "krylov");
  const ParameterMap& r = c.reducer_params;
  EXPECT_EQ(r.owner(), "reducer 'krylov'");
  EXPECT_EQ(r.keys(), (std::vector<std::string>{"batch", "empty", "method", "outputs", "points_hz",
                                                "shift", "tag", "two_sided"}));
  EXPECT_EQ(r.location("two_sided"), "full.yaml:7");
  EXPECT_EQ(r.location("outputs"), "full.yaml:12");
  EXPECT_TRUE(r.get_bool("two_sided", false));
  EXPECT_EQ(r.get_int("batch", 0), 4);
  EXPECT_EQ(r.get_double("shift", 0.0), -1.5);
  EXPECT_EQ(r.get_string("method", ""), "arnoldi");
  EXPECT_EQ(r.get_doubles("points_hz", {}), (std::vector<double>{0.1, 1.0, 25.0}));
  EXPECT_EQ(r.get_doubles("empty", {9.0}), std::vector<double>{});
  // A quoted number is text: the user said so.
  EXPECT_EQ(r.get_string("tag", ""), "123");
  // Integers stay integers, numbers stay numbers: the type shows in a type error.
  EXPECT_NE(config_error([&] { r.get_bool("batch", false); }).find("not an integer"),
            std::string::npos);
  EXPECT_NE(config_error([&] { r.get_bool("shift", false); }).find("not a number"),
            std::string::npos);
  // outputs is a list of strings and is rejected as a list of numbers.
  EXPECT_THROW(r.get_doubles("outputs", {}), ConfigError);
  EXPECT_NO_THROW(r.check_unused());

  EXPECT_EQ(c.strategy_name, "greedy");
  EXPECT_EQ(c.strategy_params.owner(), "strategy 'greedy'");
  EXPECT_EQ(c.strategy_params.get_int("max_order", 0), 80);
  EXPECT_EQ(c.strategy_params.get_double("growth", 0.0), 1.5);
  EXPECT_FALSE(c.strategy_params.has("name"));

  EXPECT_EQ(c.error.grid_points, 300);
  EXPECT_FALSE(c.error.pole_samples);
  EXPECT_EQ(c.error.max_pole_samples, 50);
  EXPECT_EQ(c.error.refine_peaks, 7);
  EXPECT_EQ(c.error.refine_evaluations, 12);
  EXPECT_EQ(c.error.zero_threshold, 1.0e-12);
  EXPECT_EQ(c.verify_factor, 8);

  EXPECT_EQ(c.threads, 2);
  EXPECT_FALSE(c.solver.use_cholesky);
  EXPECT_EQ(c.solver.symmetry_tol, 1.0e-10);
  EXPECT_EQ(c.solver.singular_rcond, 1e-15);

  EXPECT_EQ(c.output_dir, fs::path("/tmp/ecmor_out"));
  ASSERT_EQ(c.plugins.size(), 2u);
  EXPECT_EQ(c.plugins[0], (cwd / "plugins/libx.so").lexically_normal());
  EXPECT_EQ(c.plugins[1], fs::path("/opt/ecmor/plugins"));
}

TEST(RunConfig, DefaultsOfOptionalSections) {
  const RunConfig c = parse_run_config(kMinimal, "run.yaml");
  const BandErrorOptions defaults;
  const SolverOptions solver_defaults;
  EXPECT_EQ(c.norm, ErrorNorm::Spectral);
  EXPECT_EQ(c.strategy_name, "grow_order");
  EXPECT_EQ(c.strategy_params.owner(), "strategy 'grow_order'");
  EXPECT_TRUE(c.strategy_params.keys().empty());
  EXPECT_TRUE(c.reducer_params.keys().empty());
  EXPECT_EQ(c.error.grid_points, defaults.grid_points);
  EXPECT_EQ(c.error.pole_samples, defaults.pole_samples);
  EXPECT_EQ(c.error.max_pole_samples, defaults.max_pole_samples);
  EXPECT_EQ(c.error.refine_peaks, defaults.refine_peaks);
  EXPECT_EQ(c.error.refine_evaluations, defaults.refine_evaluations);
  EXPECT_EQ(c.error.zero_threshold, defaults.zero_threshold);
  EXPECT_EQ(c.verify_factor, 4);
  EXPECT_EQ(c.threads, 0);
  EXPECT_EQ(c.solver.use_cholesky, solver_defaults.use_cholesky);
  EXPECT_EQ(c.solver.symmetry_tol, solver_defaults.symmetry_tol);
  EXPECT_EQ(c.solver.singular_rcond, solver_defaults.singular_rcond);
  EXPECT_TRUE(c.plugins.empty());
  EXPECT_EQ(c.output_dir, (fs::current_path() / "out/lf10").lexically_normal());
  // Integer-valued band limits are numbers too.
  EXPECT_EQ(c.band.f_max_hz, 100.0);
  EXPECT_EQ(c.hinf_dense_states, 250);
  EXPECT_EQ(c.stability_dense_states, 1000);
  EXPECT_EQ(c.check_max_order, 0);
  EXPECT_EQ(c.check_max_seconds, 0.0);
  EXPECT_TRUE(c.portfolio.empty());
}

TEST(RunConfig, StrategySectionWithoutNameKeepsTheDefault) {
  const RunConfig c = parse_run_config(kMinimal + "strategy: {max_order: 7}\n", "run.yaml");
  EXPECT_EQ(c.strategy_name, "grow_order");
  EXPECT_EQ(c.strategy_params.get_int("max_order", 0), 7);
}

// backend: {name: ...} picks the shifted solver; anything else is named with the rule.
TEST(RunConfig, BackendSection) {
  EXPECT_EQ(parse_run_config(kMinimal, "run.yaml").solver.backend, "suitesparse");
  EXPECT_EQ(parse_run_config(kMinimal + "backend: {name: petsc}\n", "run.yaml").solver.backend,
            "petsc");
  const std::string e = parse_error(kMinimal + "backend: {name: mpi}\n");
  EXPECT_NE(e.find("run.yaml:12: backend.name = 'mpi': must be one of suitesparse, petsc"),
            std::string::npos)
      << e;
  EXPECT_NE(parse_error(kMinimal + "backend: {name: petsc, ranks: 2}\n").find("ranks"),
            std::string::npos);
}

TEST(RunConfig, SolverOrderingAndComplexSymmetricFactorisation) {
  const RunConfig d = parse_run_config(kMinimal, "run.yaml");
  EXPECT_EQ(d.solver.ordering, "auto");
  EXPECT_EQ(d.solver.complex_symmetric, "auto");
  EXPECT_EQ(d.solver.ldlt_memory_fraction, SolverOptions{}.ldlt_memory_fraction);
  const RunConfig c = parse_run_config(
      kMinimal + "solver: {ordering: metis, complex_symmetric: ldlt, ldlt_memory_fraction: 0.5}\n",
      "run.yaml");
  EXPECT_EQ(c.solver.ordering, "metis");
  EXPECT_EQ(c.solver.complex_symmetric, "ldlt");
  EXPECT_EQ(c.solver.ldlt_memory_fraction, 0.5);
  EXPECT_EQ(parse_error(kMinimal + "solver: {ordering: nd}\n"),
            "run.yaml:12: solver.ordering = 'nd': must be one of auto, amd, metis "
            "(did you mean 'amd'?)");
  EXPECT_EQ(parse_error(kMinimal + "solver: {complex_symmetric: llt}\n"),
            "run.yaml:12: solver.complex_symmetric = 'llt': must be one of auto, ldlt, "
            "lu (did you mean 'ldlt'?)");
  EXPECT_EQ(parse_error(kMinimal + "solver: {ldlt_memory_fraction: 2}\n"),
            "run.yaml:12: solver.ldlt_memory_fraction = 2: must be in [0, 1]");
}

TEST(RunConfig, CheckSectionAndHinfDenseStates) {
  const RunConfig c = parse_run_config(
      kMinimal + "check: {max_order: 12, max_seconds: 30}\nerror: {hinf_dense_states: 0}\n",
      "run.yaml");
  EXPECT_EQ(c.check_max_order, 12);
  EXPECT_EQ(c.check_max_seconds, 30.0);
  EXPECT_EQ(c.hinf_dense_states, 0);
  EXPECT_EQ(parse_run_config(kMinimal + "error: {stability_dense_states: 0}\n", "run.yaml")
                .stability_dense_states,
            0);
  // 0 is no budget, the default.
  EXPECT_EQ(parse_run_config(kMinimal + "check: {max_order: 0, max_seconds: 0}\n", "run.yaml")
                .check_max_order,
            0);
  EXPECT_EQ(parse_error(kMinimal + "check: {max_order: -1}\n"),
            "run.yaml:12: check.max_order = -1: must be >= 0");
  EXPECT_EQ(parse_error(kMinimal + "check: {max_seconds: -1}\n"),
            "run.yaml:12: check.max_seconds = -1: must be >= 0 and finite");
  EXPECT_EQ(parse_error(kMinimal + "error: {stability_dense_states: 7000}\n"),
            "run.yaml:12: error.stability_dense_states = 7000: must be in [0, 6000]");
  EXPECT_NE(parse_error(kMinimal + "error: {hinf_dense_states: 7000}\n")
                .find("hinf_dense_states = 7000: must be in [0, 6000]"),
            std::string::npos);
}

TEST(RunConfig, ExampleInTheHeaderParses) {
  // Read the example from config.hpp itself, so the documentation cannot drift from the parser.
  std::ifstream header(fs::path(ECMOR_TEST_SOURCE_DIR) / "run/include/ecmor/run/config.hpp");
  ASSERT_TRUE(header) << "cannot open config.hpp";
  std::string line, yaml;
  bool in_example = false;
  while (std::getline(header, line)) {
    if (line.find("Example:") != std::string::npos) {
      in_example = true;
      continue;
    }
    if (!in_example) continue;
    if (line == "///") {
      if (yaml.empty()) continue;  // blank comment lines before the example
      break;
    }
    ASSERT_EQ(line.rfind("///   ", 0), 0u) << line;
    yaml += line.substr(6) + "\n";
  }
  ASSERT_NE(yaml.find("plugins:"), std::string::npos) << yaml;
  const RunConfig c = parse_run_config(yaml, "config.hpp example");
  EXPECT_EQ(c.model.path.filename(), "triplechain_saak09_n451");
  EXPECT_EQ(c.band.f_min_hz, 1.0e-5);
  EXPECT_EQ(c.band.f_max_hz, 10.0);
  EXPECT_EQ(c.tolerance, 1.0e-3);
  EXPECT_EQ(c.reducer_name, "modal");
  EXPECT_TRUE(c.reducer_params.get_bool("static_correction", false));
  EXPECT_EQ(c.strategy_params.get_int("max_order", 0), 200);
  EXPECT_EQ(c.error.grid_points, 200);
  EXPECT_EQ(c.error.refine_peaks, 5);
  EXPECT_EQ(c.plugins.size(), 2u);
}

TEST(RunConfig, UnknownKeysSuggestTheNearest) {
  EXPECT_EQ(parse_error(replace(kMinimal, "  tolerance:", "  tolerence:")),
            "run.yaml:7: unknown key 'tolerence' in 'target' (did you mean 'tolerance'?)");
  EXPECT_EQ(parse_error(kMinimal + "reduser: {name: x}\n"),
            "run.yaml:12: unknown key 'reduser' in the configuration (did you mean 'reducer'?)");
  EXPECT_EQ(parse_error(kMinimal + "error: {grid_point: 10}\n"),
            "run.yaml:12: unknown key 'grid_point' in 'error' (did you mean 'grid_points'?)");
  EXPECT_EQ(parse_error(kMinimal + "solver: {thread: 1}\n"),
            "run.yaml:12: unknown key 'thread' in 'solver' (did you mean 'threads'?)");
  EXPECT_EQ(parse_error(replace(kMinimal, "  f_min_hz:", "  fmin:")),
            "run.yaml:4: unknown key 'fmin' in 'band' (valid: f_min_hz, f_max_hz)");
  // Every unknown key is listed, not just the first.
  EXPECT_EQ(
      parse_error(kMinimal + "colour: red\nverbose: true\n"),
      "run.yaml:12: unknown key 'colour' in the configuration (valid: model, band, target, "
      "reducer, strategy, error, solver, backend, output, check, plugins, compress); run.yaml:13: "
      "unknown key 'verbose' in the configuration (valid: model, band, target, reducer, "
      "strategy, error, solver, backend, output, check, plugins, compress)");
}

TEST(RunConfig, ErrorControlModeAndItsBudgets) {
  const RunConfig c = parse_run_config(
      kMinimal +
          "error: {verify: estimate, dense_max_states: 500, estimate_points: 900,\n"
          "        reference_points: 9, check_peaks: 3, random_checks: 0, check_rounds: 2,\n"
          "        probe_solves: 0}\n",
      "run.yaml");
  EXPECT_EQ(c.error.verify, ErrorVerify::Estimate);
  EXPECT_EQ(c.error.dense_max_states, 500);
  EXPECT_EQ(c.error.estimate_points, 900);
  EXPECT_EQ(c.error.reference_points, 9);
  EXPECT_EQ(c.error.check_peaks, 3);
  EXPECT_EQ(c.error.random_checks, 0);
  EXPECT_EQ(c.error.check_rounds, 2);
  EXPECT_EQ(c.error.probe_solves, 0);
  EXPECT_EQ(parse_run_config(kMinimal, "run.yaml").error.verify, BandErrorOptions{}.verify);
  EXPECT_EQ(parse_error(kMinimal + "error: {verify: estimat}\n"),
            "run.yaml:12: error.verify = 'estimat': must be one of dense, estimate, "
            "auto (did you mean 'estimate'?)");
  EXPECT_NE(parse_error(kMinimal + "error: {reference_points: 1}\n").find("reference_points"),
            std::string::npos);
  EXPECT_NE(parse_error(kMinimal + "error: {check_peaks: 0}\n").find("check_peaks"),
            std::string::npos);
}

TEST(RunConfig, DuplicateKeysAreErrors) {
  // yaml-cpp would silently keep the first value.
  EXPECT_EQ(parse_error(replace(kMinimal, "  tolerance: 1.0e-3\n",
                                "  tolerance: 1.0e-3\n  tolerance: 1.0e-5\n")),
            "run.yaml:8: duplicate key 'tolerance' in 'target' (first given at line 7)");
  EXPECT_EQ(parse_error(kMinimal + "band: {f_min_hz: 1, f_max_hz: 2}\n"),
            "run.yaml:12: duplicate key 'band' in the configuration (first given at line 3)");
}

TEST(RunConfig, MissingRequiredKeys) {
  EXPECT_EQ(parse_error(replace(kMinimal, "  dir: models/lf10\n", "  {}\n")),
            "run.yaml:2: missing required key 'model.dir' (a model directory) or "
            "'model.file' (a .mat file)");
  EXPECT_EQ(parse_error(replace(kMinimal, "  f_max_hz: 100\n", "")),
            "run.yaml:4: missing required key 'band.f_max_hz'");
  EXPECT_EQ(parse_error(replace(kMinimal, "  tolerance: 1.0e-3\n", "  norm: spectral\n")),
            "run.yaml:7: missing required key 'target.tolerance'");
  EXPECT_EQ(parse_error(replace(kMinimal, "  name: modal\n", "  order: 3\n")),
            "run.yaml:9: missing required key 'reducer.name'");
  EXPECT_EQ(parse_error(replace(kMinimal, "  dir: out/lf10\n", "  {}\n")),
            "run.yaml:11: missing required key 'output.dir'");
  EXPECT_EQ(parse_error(replace(kMinimal, "output:\n  dir: out/lf10\n", "")),
            "run.yaml:1: missing required section 'output'");
  // A section present but empty.
  EXPECT_EQ(parse_error(replace(kMinimal, "model:\n  dir: models/lf10\n", "model:\n")),
            "run.yaml:1: missing required key 'model.dir' (a model directory) or "
            "'model.file' (a .mat file)");
}

TEST(RunConfig, WrongTypes) {
  EXPECT_EQ(parse_error(replace(kMinimal, "tolerance: 1.0e-3", "tolerance: small")),
            "run.yaml:7: target.tolerance = 'small': must be a number, not a string");
  EXPECT_EQ(parse_error(replace(kMinimal, "tolerance: 1.0e-3", "tolerance: {value: 1}")),
            "run.yaml:7: target.tolerance: nested mappings are not supported (a parameter is a "
            "value or a list)");
  EXPECT_EQ(parse_error(replace(kMinimal, "f_min_hz: 0.1", "f_min_hz: [0.1, 1]")),
            "run.yaml:4: band.f_min_hz = [0.1, 1]: must be a number, not a list of numbers");
  EXPECT_EQ(parse_error(replace(kMinimal, "f_min_hz: 0.1", "f_min_hz:")),
            "run.yaml:4: band.f_min_hz has no value");
  EXPECT_EQ(parse_error(replace(kMinimal, "band:\n  f_min_hz: 0.1\n  f_max_hz: 100\n",
                                "band: [0.1, 100]\n")),
            "run.yaml:3: 'band' must be a mapping of keys (f_min_hz, f_max_hz), found a list");
  EXPECT_EQ(parse_error(kMinimal + "error: {grid_points: 20.5}\n"),
            "run.yaml:12: error.grid_points = 20.5: must be an integer");
  EXPECT_EQ(parse_error(kMinimal + "error: {pole_samples: maybe}\n"),
            "run.yaml:12: error.pole_samples = 'maybe': must be true or false, not a "
            "string");
  EXPECT_EQ(parse_error(kMinimal + "solver: {use_cholesky: 1}\n"),
            "run.yaml:12: solver.use_cholesky = 1: must be true or false, not an "
            "integer");
  EXPECT_EQ(parse_error(replace(kMinimal, "  name: modal\n", "  name: [modal]\n")),
            "run.yaml:9: reducer.name = ['modal']: must be a string, not a list of strings");
  EXPECT_EQ(parse_error(kMinimal + "plugins: {a: 1}\n"),
            "run.yaml:12: plugins: nested mappings are not supported (a parameter is a value or a "
            "list)");
  EXPECT_EQ(parse_error(kMinimal + "plugins: [[a, b]]\n"),
            "run.yaml:12: plugins: list items must be single values, found a list");
  // Integral floats are integers.
  EXPECT_EQ(
      parse_run_config(kMinimal + "error: {grid_points: 1e3}\n", "run.yaml").error.grid_points,
      1000);
}

TEST(RunConfig, RangesAreChecked) {
  EXPECT_EQ(parse_error(replace(kMinimal, "f_min_hz: 0.1", "f_min_hz: -1")),
            "run.yaml:4: band.f_min_hz = -1: must be > 0 and finite (the band is sampled in log "
            "scale, and f = 0 is a pole of H for a model with rigid-body modes, e.g. a "
            "free-floating body)");
  EXPECT_EQ(parse_error(replace(kMinimal, "f_min_hz: 0.1", "f_min_hz: 0")),
            "run.yaml:4: band.f_min_hz = 0: must be > 0 and finite (the band is sampled in log "
            "scale, and f = 0 is a pole of H for a model with rigid-body modes, e.g. a "
            "free-floating body)");
  EXPECT_EQ(parse_error(replace(kMinimal, "f_max_hz: 100", "f_max_hz: 0.1")),
            "run.yaml:5: band.f_max_hz = 0.1: must be > f_min_hz = 0.1");
  EXPECT_EQ(parse_error(replace(kMinimal, "f_max_hz: 100", "f_max_hz: .inf")),
            "run.yaml:5: band.f_max_hz = inf: must be > 0 and finite");
  EXPECT_EQ(parse_error(replace(kMinimal, "f_min_hz: 0.1", "f_min_hz: .nan")),
            "run.yaml:4: band.f_min_hz = nan: must be a number, not NaN");
  EXPECT_EQ(parse_error(replace(kMinimal, "tolerance: 1.0e-3", "tolerance: 0")),
            "run.yaml:7: target.tolerance = 0: must be in (0, 1000]");
  EXPECT_EQ(parse_error(replace(kMinimal, "tolerance: 1.0e-3", "tolerance: -1e-3")),
            "run.yaml:7: target.tolerance = -0.001: must be in (0, 1000]");
  EXPECT_EQ(parse_error(replace(kMinimal, "tolerance: 1.0e-3", "tolerance: 1001")),
            "run.yaml:7: target.tolerance = 1001: must be in (0, 1000]");
  // The upper bound is inclusive.
  EXPECT_EQ(
      parse_run_config(replace(kMinimal, "tolerance: 1.0e-3", "tolerance: 1e3"), "r").tolerance,
      1e3);
  EXPECT_EQ(parse_error(kMinimal + "error: {grid_points: 1}\n"),
            "run.yaml:12: error.grid_points = 1: must be in [2, 1000000]");
  EXPECT_EQ(parse_error(kMinimal + "error: {refine_peaks: -1}\n"),
            "run.yaml:12: error.refine_peaks = -1: must be >= 0");
  // A re-check grid no denser than the estimator's would check nothing.
  EXPECT_EQ(parse_error(kMinimal + "error: {verify_factor: 1}\n"),
            "run.yaml:12: error.verify_factor = 1: must be >= 2");
  EXPECT_EQ(parse_error(kMinimal + "error: {zero_threshold: 1}\n"),
            "run.yaml:12: error.zero_threshold = 1: must be in [0, 1)");
  EXPECT_EQ(parse_error(kMinimal + "solver: {threads: -2}\n"),
            "run.yaml:12: solver.threads = -2: must be in [0, 65536]");
  EXPECT_EQ(parse_error(kMinimal + "solver: {symmetry_tol: -1e-3}\n"),
            "run.yaml:12: solver.symmetry_tol = -0.001: must be in [0, 1)");
  EXPECT_EQ(parse_error(replace(kMinimal, "tolerance: 1.0e-3\n",
                                "tolerance: 1.0e-3\n  norm: "
                                "frobenus\n")),
            "run.yaml:8: target.norm = 'frobenus': must be one of spectral, frobenius (did you "
            "mean 'frobenius'?)");
}

// strategy.time_limit_s is the driver's wall-clock budget: read into RunConfig, not handed to the
// strategy as a parameter (which would reject it as unknown); 0 is no limit, the default.
TEST(RunConfig, TimeLimitIsTheDriversKey) {
  const RunConfig none = parse_run_config(kMinimal, "r");
  EXPECT_EQ(none.time_limit_s, 0.0);
  const RunConfig c = parse_run_config(
      kMinimal + "strategy:\n  name: grow_order\n  time_limit_s: 90\n  max_order: 7\n", "r");
  EXPECT_EQ(c.time_limit_s, 90.0);
  EXPECT_FALSE(c.strategy_params.has("time_limit_s"));
  EXPECT_TRUE(c.strategy_params.has("max_order"));
  EXPECT_EQ(parse_run_config(kMinimal + "strategy:\n  time_limit_s: 0\n", "r").time_limit_s, 0.0);
  EXPECT_EQ(parse_error(kMinimal + "strategy:\n  time_limit_s: -5\n"),
            "run.yaml:13: strategy.time_limit_s = -5: must be >= 0 and finite");
  EXPECT_EQ(parse_error(kMinimal + "strategy:\n  time_limit_s: .inf\n"),
            "run.yaml:13: strategy.time_limit_s = inf: must be >= 0 and finite");
  EXPECT_EQ(parse_error(kMinimal + "strategy:\n  time_limit_s: soon\n"),
            "run.yaml:13: strategy.time_limit_s = 'soon': must be a number, not a string");
}

TEST(RunConfig, ReducerParameterRules) {
  EXPECT_EQ(parse_error(replace(kMinimal, "  name: modal\n", "  name: modal\n  opts: {a: 1}\n")),
            "run.yaml:10: reducer.opts: nested mappings are not supported (a parameter is a "
            "value or a list)");
  EXPECT_EQ(parse_error(replace(kMinimal, "  name: modal\n", "  name: modal\n  mix: [1, a]\n")),
            "run.yaml:10: reducer.mix: list mixes numbers and text ('a')");
  EXPECT_EQ(parse_error(replace(kMinimal, "  name: modal\n", "  name: modal\n  shifts:\n")),
            "run.yaml:10: reducer.shifts has no value");
  EXPECT_EQ(parse_error(kMinimal + "strategy: {name: greedy, nested: [[1]]}\n"),
            "run.yaml:12: strategy.nested: list items must be single values, found a list");
  EXPECT_EQ(parse_error(replace(kMinimal, "  name: modal\n", "  name: modal\n  n: 1\n  n: 2\n")),
            "run.yaml:11: duplicate key 'n' in 'reducer' (first given at line 10)");
  // Scalar classification: YAML booleans, +sign, special floats, everything else text.
  const RunConfig c = parse_run_config(
      replace(kMinimal, "  name: modal\n",
              "  name: modal\n  a: yes\n  b: False\n  c: +7\n  d: -.inf\n  e: 1.5e-3\n  f: 0x10\n"
              "  g: 'true'\n"),
      "run.yaml");
  const ParameterMap& p = c.reducer_params;
  EXPECT_TRUE(p.get_bool("a", false));
  EXPECT_FALSE(p.get_bool("b", true));
  EXPECT_EQ(p.get_int("c", 0), 7);
  EXPECT_EQ(p.get_double("d", 0.0), -std::numeric_limits<double>::infinity());
  EXPECT_EQ(p.get_double("e", 0.0), 1.5e-3);
  EXPECT_EQ(p.get_string("f", ""), "0x10");
  EXPECT_EQ(p.get_string("g", ""), "true");
  // Parameter errors raised later by a plugin still carry the YAML line.
  EXPECT_EQ(config_error([&] { p.get_int("e", 0); }),
            "run.yaml:14: reducer 'modal': e = 0.0015: must be an integer");
}

TEST(RunConfig, SyntaxErrorsEmptyAndNonMappingDocuments) {
  const std::string syntax =
      parse_error(replace(kMinimal, "  f_max_hz: 100\n", "  f_max_hz: [1, 2\n"));
  EXPECT_EQ(syntax.rfind("run.yaml:", 0), 0u) << syntax;
  EXPECT_NE(syntax.find("YAML syntax error"), std::string::npos) << syntax;
  const std::string bad_indent = parse_error("model:\n  dir: a\n dir2: b\n");
  EXPECT_EQ(bad_indent.rfind("run.yaml:3: YAML syntax error: ", 0), 0u) << bad_indent;
  EXPECT_EQ(parse_error(""),
            "run.yaml: the file is empty (expected the sections model, band, "
            "target, reducer, strategy, error, solver, backend, output, check, plugins, compress)");
  EXPECT_EQ(parse_error("# only a comment\n\n"),
            "run.yaml: the file is empty (expected the sections model, band, target, reducer, "
            "strategy, error, solver, backend, output, check, plugins, compress)");
  EXPECT_EQ(parse_error("- a\n- b\n"),
            "run.yaml:1: expected a mapping of sections (model, band, target, reducer, strategy, "
            "error, solver, backend, output, check, plugins, compress), found a list");
}

TEST(RunConfig, LoadFromFile) {
  const fs::path dir =
      fs::temp_directory_path() / ("ecmor_config_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path file = dir / "run.yaml";
  std::ofstream(file) << kMinimal;
  const RunConfig c = load_run_config(file);
  EXPECT_EQ(c.source, file);
  EXPECT_EQ(c.reducer_name, "modal");

  // Messages name the file as given.
  std::ofstream(file) << replace(kMinimal, "  tolerance:", "  tolerence:");
  EXPECT_EQ(config_error([&] { load_run_config(file); }),
            file.string() + ":7: unknown key 'tolerence' in 'target' (did you mean 'tolerance'?)");

  const fs::path missing = dir / "nothing.yaml";
  EXPECT_EQ(config_error([&] { load_run_config(missing); }),
            missing.string() + ": configuration file not found");
  EXPECT_EQ(config_error([&] { load_run_config(dir); }),
            dir.string() + ": is a directory, not a configuration file");

  std::ofstream(file, std::ios::trunc).close();
  EXPECT_EQ(
      config_error([&] { load_run_config(file); }).rfind(file.string() + ": the file is empty", 0),
      0u);
  fs::remove_all(dir);
}
