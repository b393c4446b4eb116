// libFuzzer target: the YAML run-configuration loader (run/src/config.cpp) and the parameter
// map it fills (core/src/base/parameters.cpp), on arbitrary text.
//
// parse_run_config is the in-memory entry point of load_run_config (which only reads the file
// and calls it). Besides the sanitizers, the harness aborts, i.e. reports a crash, when
//  * anything but an ecmor::ConfigError escapes the loader or a parameter accessor;
//  * a loader message does not start with the configuration's name;
//  * an accepted configuration breaks a documented range (band, tolerance, counts, threads).
// Accepted configurations then have every reducer/strategy parameter read with every accessor,
// as plugins do, and check_unused() run.
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "ecmor/base/error.hpp"
#include "ecmor/base/parameters.hpp"
#include "ecmor/run/config.hpp"

using namespace ecmor;

namespace {

const std::string kName = "fuzz.yaml";

[[noreturn]] void contract(const std::string& what) {
  std::fprintf(stderr, "\n*** fuzz_config: contract violated: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

/// Runs f; a ConfigError is an expected outcome, anything else escaping breaks the contract.
template <class F>
void expect_config_error_only(const char* what, F&& f) {
  try {
    f();
  } catch (const ConfigError&) {
  } catch (const std::exception& e) {
    contract(std::string(what) + " threw something else than a ConfigError: " + e.what());
  } catch (...) {
    contract(std::string(what) + " threw a non-std exception");
  }
}

void exercise(const ParameterMap& params) {
  for (const std::string& key : params.keys()) {
    (void)params.location(key);
    expect_config_error_only("get_bool", [&] { (void)params.get_bool(key, false); });
    expect_config_error_only("get_int", [&] { (void)params.get_int(key, 1); });
    expect_config_error_only("get_int (bounded)", [&] { (void)params.get_int(key, 1, 1, 1000); });
    expect_config_error_only("get_double", [&] { (void)params.get_double(key, 0.5); });
    expect_config_error_only("get_double (bounded)",
                             [&] { (void)params.get_double(key, 0.5, 0.0, 1.0); });
    expect_config_error_only("get_string", [&] { (void)params.get_string(key, "x"); });
    expect_config_error_only("get_string (choices)", [&] {
      (void)params.get_string(key, "spectral", {"spectral", "frobenius", "modal"});
    });
    expect_config_error_only("get_doubles", [&] { (void)params.get_doubles(key, {}); });
  }
  // Once with every key unread (suggestions against nothing), once with all read.
  ParameterMap fresh(params.owner());
  for (const std::string& key : params.keys()) fresh.set(key, ParameterValue{});
  expect_config_error_only("check_unused", [&] { fresh.check_unused(); });
  expect_config_error_only("check_unused", [&] { params.check_unused(); });
}

/// Whether the YAML text gives strategy.members at all. Without it a portfolio runs the bundled
/// reducers that suit the model (docs/strategies.md); given, it must hold at least one member.
bool members_given(const std::string& yaml) {
  try {
    const YAML::Node strategy = YAML::Load(yaml)["strategy"];
    return strategy.IsMap() && strategy["members"].IsDefined();
  } catch (const YAML::Exception&) {
    return true;  // parse_run_config accepted it, so this does not happen; count it as given
  }
}

void check_ranges(const RunConfig& c, const std::string& yaml) {
  if (!(c.band.f_min_hz > 0.0 && c.band.f_max_hz > c.band.f_min_hz &&
        std::isfinite(c.band.f_max_hz)))
    contract("accepted a band that is not 0 < f_min < f_max < inf");
  if (!(c.tolerance > 0.0 && c.tolerance <= 1e3)) contract("accepted a tolerance outside (0, 1e3]");
  if (c.verify_factor < 2) contract("accepted error.verify_factor < 2");
  if (c.error.grid_points < 2) contract("accepted error.grid_points < 2");
  if (c.threads < 0 || c.threads > 65536) contract("accepted solver.threads outside [0, 65536]");
  if (c.hinf_dense_states < 0 || c.hinf_dense_states > 6000)
    contract("accepted error.hinf_dense_states outside [0, 6000]");
  if (!(c.time_limit_s >= 0.0) || !std::isfinite(c.time_limit_s))
    contract("accepted a negative or non-finite strategy.time_limit_s");
  if (c.model.path.empty() || c.output_dir.empty())
    contract("accepted an empty model or output dir");
  if (c.reducer_name.empty()) contract("accepted an empty reducer name");
  if (c.strategy_name == "portfolio" && c.portfolio.empty() && members_given(yaml))
    contract("accepted a portfolio whose members list is empty");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string yaml(reinterpret_cast<const char*>(data), size);
  RunConfig config;
  bool parsed = false;
  try {
    config = parse_run_config(yaml, kName);
    parsed = true;
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    if (msg.rfind(kName, 0) != 0) contract("message does not start with the file name: " + msg);
  } catch (const std::exception& e) {
    contract(std::string("parse_run_config threw something else than a ConfigError: ") + e.what());
  } catch (...) {
    contract("parse_run_config threw a non-std exception");
  }
  if (!parsed) return 0;
  check_ranges(config, yaml);
  exercise(config.reducer_params);
  exercise(config.strategy_params);
  for (const PortfolioMember& m : config.portfolio) {
    if (m.reducer_name.empty() || m.strategy_name.empty() || m.strategy_name == "portfolio")
      contract("accepted a bad portfolio member");
    exercise(m.reducer_params);
    exercise(m.strategy_params);
  }
  return 0;
}
