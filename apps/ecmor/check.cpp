// `ecmor check`: every configuration is a regression test of its tolerance target. Each config is
// run exactly as `ecmor reduce` would run it; it passes when the target is met, the reported model
// meets the tolerance on the driver's independent re-check, the model is stable, and the optional
// budgets of its `check:` section (order, wall time) hold. One table, exit 1 on any failure.
#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "commands.hpp"
#include "ecmor/base/atomic_file.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/run/config.hpp"
#include "ecmor/run/driver.hpp"
#include "signals.hpp"

namespace ecmor::app {
namespace {

struct CheckRow {
  std::string config, model, reducer;
  double tolerance = 0.0;
  std::string termination;
  Index order = 0, max_order = 0;
  double verified_error = 0.0;
  double seconds = 0.0, max_seconds = 0.0;
  bool stable = false;
  std::vector<std::string> failures;  ///< empty: passed
  bool passed() const { return failures.empty(); }
};

/// The .yaml files of a directory (not recursive, sorted), or the file itself.
std::vector<std::filesystem::path> expand(const std::vector<std::filesystem::path>& inputs) {
  std::vector<std::filesystem::path> out;
  for (const auto& p : inputs) {
    std::error_code ec;
    if (std::filesystem::is_directory(p, ec)) {
      std::vector<std::filesystem::path> found;
      for (const auto& e : std::filesystem::directory_iterator(p)) {
        if (e.is_regular_file() && e.path().extension() == ".yaml") found.push_back(e.path());
      }
      if (found.empty())
        throw ConfigError(p.string() + ": no *.yaml configuration in this directory");
      std::sort(found.begin(), found.end());
      out.insert(out.end(), found.begin(), found.end());
    } else {
      out.push_back(p);  // load_run_config names a missing file
    }
  }
  return out;
}

CheckRow check_one(const RunConfig& base, const std::filesystem::path& out_dir,
                   const CommonOptions& common) {
  CheckRow row;
  row.config = base.source.string();
  row.model = base.model.path.filename().string();
  row.reducer = base.reducer_name + "/" + base.strategy_name;
  row.tolerance = base.tolerance;
  row.max_order = base.check_max_order;
  row.max_seconds = base.check_max_seconds;
  RunConfig config = base;
  config.output_dir = out_dir;
  try {
    Registry registry;
    load_plugins(registry, common, config.plugins);
    StopOnSignal observer;
    const RunSummary s = run_reduction(config, registry, &observer);
    row.termination = to_string(s.termination);
    if (config.is_portfolio() && s.has_model) {
      row.reducer = "portfolio: " + s.reducer + "/" + s.strategy;
    }
    row.order = s.has_model ? s.order : 0;
    row.verified_error = s.verified_band_error;
    row.seconds = s.seconds;
    row.stable = s.stable;
    if (s.termination != Termination::Converged) {
      row.failures.push_back(fmt::format("target not met ({}: {})", row.termination, s.message));
    }
    if (!s.has_model) {
      row.failures.push_back("no reduced model");
    } else {
      if (!(s.verified_band_error <= config.tolerance)) {
        row.failures.push_back(fmt::format("independent re-check {:.3e} > tolerance {:g}",
                                           s.verified_band_error, config.tolerance));
      }
      if (!s.stable) row.failures.push_back("reduced model not stable: " + s.stability.reason);
      if (row.max_order > 0 && s.order > row.max_order) {
        row.failures.push_back(
            fmt::format("order {} > check.max_order {}", s.order, row.max_order));
      }
    }
    if (row.max_seconds > 0.0 && s.seconds > row.max_seconds) {
      row.failures.push_back(
          fmt::format("{:.1f} s > check.max_seconds {:g}", s.seconds, row.max_seconds));
    }
  } catch (const std::exception& e) {
    row.termination = "error";
    row.failures.push_back(e.what());
  }
  return row;
}

std::string budget(double value, double limit, const char* fmt_value) {
  const std::string v = fmt::format(fmt::runtime(fmt_value), value);
  return limit > 0.0 ? v + fmt::format(" (<= {:g})", limit) : v;
}

std::string table(const std::vector<CheckRow>& rows) {
  std::string out =
      "| config | model | reducer/strategy | tolerance | re-checked error | order | seconds | "
      "result |\n|---|---|---|---:|---:|---:|---:|---|\n";
  for (const CheckRow& r : rows) {
    out += fmt::format(
        "| {} | {} | {} | {:g} | {:.3e} | {} | {} | {} |\n",
        std::filesystem::path(r.config).filename().string(), r.model, r.reducer, r.tolerance,
        r.verified_error,
        budget(static_cast<double>(r.order), static_cast<double>(r.max_order), "{:.0f}"),
        budget(r.seconds, r.max_seconds, "{:.1f}"),
        r.passed() ? std::string("PASS")
                   : "FAIL: " + fmt::format("{}", fmt::join(r.failures, "; ")));
  }
  return out;
}

nlohmann::json to_json(const CheckRow& r) {
  return {{"config", r.config},           {"model", r.model},
          {"reducer", r.reducer},         {"tolerance", r.tolerance},
          {"termination", r.termination}, {"order", r.order},
          {"max_order", r.max_order},     {"verified_band_error", r.verified_error},
          {"seconds", r.seconds},         {"max_seconds", r.max_seconds},
          {"stable", r.stable},           {"passed", r.passed()},
          {"failures", r.failures}};
}

}  // namespace

int check(const CheckOptions& options, const CommonOptions& common) {
  return guarded([&] {
    if (options.inputs.empty()) throw ConfigError("ecmor check: no configuration given");
    // Every config is read first: a typo in the last one must not surface after an hour of runs.
    std::vector<RunConfig> configs;
    for (const auto& path : expand(options.inputs)) configs.push_back(load_run_config(path));
    install_stop_signals();

    const std::filesystem::path out = std::filesystem::absolute(options.output_dir);
    std::vector<CheckRow> rows;
    std::set<std::string> used;
    const auto start = std::chrono::steady_clock::now();
    for (std::size_t k = 0; k < configs.size() && !stop_signalled(); ++k) {
      std::string name = configs[k].source.stem().string();
      for (int n = 2; used.count(name) > 0; ++n) {
        name = configs[k].source.stem().string() + "_" + std::to_string(n);
      }
      used.insert(name);
      if (!common.quiet) {
        fmt::print("[{}/{}] {} ... ", k + 1, configs.size(), configs[k].source.filename().string());
        std::fflush(stdout);
      }
      rows.push_back(check_one(configs[k], out / name, common));
      const CheckRow& r = rows.back();
      if (!common.quiet) {
        const double elapsed =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        fmt::print("{} order {} error {:.2e} ({:.1f} s; {:.0f} s elapsed)\n",
                   r.passed() ? "PASS," : "FAIL,", r.order, r.verified_error, r.seconds, elapsed);
      }
      nlohmann::json j = nlohmann::json::array();
      for (const CheckRow& row : rows) j.push_back(to_json(row));
      write_text_atomically(out / "check.json", j.dump(2) + "\n");
      write_text_atomically(out / "check.md", table(rows));
    }
    const auto failed =
        std::count_if(rows.begin(), rows.end(), [](const CheckRow& r) { return !r.passed(); });
    fmt::print("\n{}\n{} of {} configurations passed{}; outputs in {}\n", table(rows),
               static_cast<long>(rows.size()) - failed, configs.size(),
               stop_signalled() ? " (interrupted)" : "", out.string());
    if (stop_signalled()) return 130;
    return failed == 0 ? 0 : 1;
  });
}

}  // namespace ecmor::app
