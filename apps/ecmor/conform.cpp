// `ecmor conform`: the reducer conformance suite (ecmor/plugin/conformance.hpp) from the command
// line, so that a plugin built out of tree can be tested with nothing but the installed ecmor and
// CTest.
#include <fmt/core.h>
#include <fmt/format.h>

#include <cerrno>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "commands.hpp"
#include "ecmor/base/atomic_file.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/plugin/conformance.hpp"
#include "ecmor/plugin/registry.hpp"

namespace ecmor::app {
namespace {

// "key=value" -> a typed parameter: true/false, an integer, a number, [a, b, ...] (numbers), else
// a string. The location names the option, as a YAML line would.
std::pair<std::string, ParameterValue> parse_setting(const std::string& text) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0)
    throw ConfigError(fmt::format("--set '{}': expected key=value", text));
  const std::string key = text.substr(0, eq);
  const std::string value = text.substr(eq + 1);
  ParameterValue v;
  v.location = "--set " + text;
  auto number = [](const std::string& s, double& out) {
    if (s.empty()) return false;
    char* end = nullptr;
    errno = 0;
    out = std::strtod(s.c_str(), &end);
    return errno == 0 && end != nullptr && *end == '\0';
  };
  double d = 0.0;
  if (value == "true" || value == "false") {
    v.value = value == "true";
  } else if (value.find_first_not_of("+-0123456789") == std::string::npos && number(value, d)) {
    v.value = static_cast<long long>(std::strtoll(value.c_str(), nullptr, 10));
  } else if (number(value, d)) {
    v.value = d;
  } else if (value.size() >= 2 && value.front() == '[' && value.back() == ']') {
    std::vector<double> list;
    std::string item;
    const std::string inner = value.substr(1, value.size() - 2) + ",";
    for (char c : inner) {
      if (c != ',') {
        if (c != ' ') item += c;
        continue;
      }
      if (item.empty()) continue;
      double x = 0.0;
      if (!number(item, x))
        throw ConfigError(fmt::format("--set {}: '{}' in the list is not a number", text, item));
      list.push_back(x);
      item.clear();
    }
    v.value = list;
  } else {
    v.value = value;
  }
  return {key, v};
}

}  // namespace

int conform(const ConformOptions& options, const CommonOptions& common) {
  return guarded([&] {
    Registry registry;
    load_plugins(registry, common, {});
    ParameterMap parameters("reducer '" + options.reducer + "'");
    for (const std::string& s : options.settings) {
      auto [key, value] = parse_setting(s);
      parameters.set(key, std::move(value));
    }
    conformance::Options opt;
    if (!options.orders.empty()) opt.orders = options.orders;
    if (options.tolerance > 0.0) opt.tolerance = options.tolerance;
    if (!options.model_dir.empty()) {
      if (options.band_hz.size() != 2)
        throw ConfigError("--model needs --band F_MIN,F_MAX (Hz) for the model's band");
      conformance::TestModel m;
      m.name = options.model_dir.filename().string();
      m.model = load_model(options.model_dir);
      m.band = Band{options.band_hz[0], options.band_hz[1]};
      m.band.validate();
      // The `band` check needs a second, disjoint band: one decade above the model's band.
      m.other_band = Band{2.0 * m.band.f_max_hz, 20.0 * m.band.f_max_hz};
      opt.models.push_back(std::move(m));
      if (options.with_builtin) {
        for (auto& b : conformance::builtin_models()) opt.models.push_back(std::move(b));
      }
    }
    bool header = common.quiet;
    const conformance::Report report = conformance::run(
        registry, options.reducer, parameters, opt, [&](const conformance::CheckResult& c) {
          if (!header) {
            fmt::print("conformance of reducer '{}'\n{:<12} {:<18} {:<5} {:>8}  {}\n",
                       options.reducer, "check", "model", "", "time", "detail");
            header = true;
          }
          if (common.quiet && c.status != conformance::Status::Failed) return;
          fmt::print("{:<12} {:<18} {:<5} {:>7.2f}s  {}\n", c.check, c.model,
                     conformance::to_string(c.status), c.seconds, c.detail);
          std::fflush(stdout);
        });
    fmt::print("{}: {} passed, {} failed, {} skipped\n", report.passed() ? "PASS" : "FAIL",
               report.count(conformance::Status::Passed), report.count(conformance::Status::Failed),
               report.count(conformance::Status::Skipped));
    if (!options.json.empty()) {
      nlohmann::json j;
      j["reducer"] = report.reducer;
      j["passed"] = report.passed();
      for (const auto& c : report.checks) {
        j["checks"].push_back({{"check", c.check},
                               {"model", c.model},
                               {"status", conformance::to_string(c.status)},
                               {"detail", c.detail},
                               {"seconds", c.seconds}});
      }
      write_text_atomically(options.json, j.dump(2) + "\n");
    }
    return report.passed() ? 0 : 1;
  });
}

}  // namespace ecmor::app
