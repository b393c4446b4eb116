// `ecmor simulate RUN_DIR`: simulates the full model and the reduced model of a finished
// `ecmor reduce` run for a step, impulse or chirp input and writes the outputs and the output
// error y - yr (seed Eq. 11). The numerics are in core (time_domain.hpp); this file picks the
// defaults from the run's band, reads and writes files and prints.
#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "commands.hpp"
#include "ecmor/base/atomic_file.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/response/time_domain.hpp"
#include "plot.hpp"

namespace ecmor::app {
namespace {

namespace fs = std::filesystem;

struct RunInfo {
  ModelSource model;
  double f_min_hz = 0.0, f_max_hz = 0.0;
};

RunInfo read_run(const fs::path& run_dir) {
  const fs::path path = run_dir / "summary.json";
  if (!fs::is_directory(run_dir)) {
    throw InputError(
        fmt::format("{}: no such run directory (expected the output directory of "
                    "`ecmor reduce`)",
                    run_dir.string()));
  }
  std::ifstream in(path);
  if (!in) {
    throw InputError(
        fmt::format("{}: missing: RUN_DIR must be the output directory of a finished "
                    "`ecmor reduce` run",
                    path.string()));
  }
  nlohmann::json j;
  try {
    in >> j;
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{}: not valid JSON ({})", path.string(), e.what()));
  }
  RunInfo info;
  try {
    // The run's model as the YAML named it: model.dir, or model.file with its variables.
    const nlohmann::json& model = j.at("model");
    if (model.contains("file")) {
      info.model.path = model.at("file").get<std::string>();
      if (model.contains("variables"))
        info.model.variables = model.at("variables").get<std::map<std::string, std::string>>();
    } else {
      info.model.path = model.at("dir").get<std::string>();
    }
    info.f_min_hz = j.at("band").at("f_min_hz").get<double>();
    info.f_max_hz = j.at("band").at("f_max_hz").get<double>();
  } catch (const nlohmann::json::exception& e) {
    throw InputError(
        fmt::format("{}: needs model.dir (or model.file), band.f_min_hz and band.f_max_hz ({})",
                    path.string(), e.what()));
  }
  if (!(info.f_min_hz > 0.0 && info.f_max_hz > info.f_min_hz && std::isfinite(info.f_max_hz))) {
    throw InputError(fmt::format("{}: band [{:g}, {:g}] Hz: must satisfy 0 < f_min_hz < f_max_hz",
                                 path.string(), info.f_min_hz, info.f_max_hz));
  }
  // A relative model path (hand-written summaries) is taken relative to the run directory.
  if (info.model.path.is_relative() && !fs::exists(info.model.path))
    info.model.path = run_dir / info.model.path;
  return info;
}

nlohmann::json response_json(const TimeResponse& r) {
  return {{"factorizations", r.factorizations},
          {"solves", r.solves},
          {"seconds", r.seconds},
          {"scheme", r.scheme}};
}

// The input as the options give it; a chirp sweeps the run's band unless --chirp-hz says otherwise.
InputSignal input_signal(const SimulateOptions& o, const RunInfo& run) {
  InputSignal input;
  input.kind = parse_input_kind(o.input);
  input.input = o.input_index;
  input.amplitude = o.amplitude;
  input.f0_hz = run.f_min_hz;
  input.f1_hz = run.f_max_hz;
  if (!o.chirp_hz.empty()) {
    if (o.chirp_hz.size() != 2)
      throw ConfigError(
          fmt::format("--chirp-hz: {} value(s): must be two, F0,F1", o.chirp_hz.size()));
    input.f0_hz = o.chirp_hz[0];
    input.f1_hz = o.chirp_hz[1];
  }
  return input;
}

// The scheme of the options; t_end and steps are chosen later (choose_time_grid).
TimeIntegrationOptions integration_options(const SimulateOptions& o) {
  TimeIntegrationOptions ti;
  ti.scheme = parse_scheme(o.scheme);
  ti.rho_inf = o.rho_inf;
  if (o.time_axis != "auto" && o.time_axis != "linear" && o.time_axis != "log")
    throw ConfigError("--time-axis = " + o.time_axis + ": must be auto, linear or log");
  return ti;
}

// How the time axis was chosen, for the report and the plot.
struct TimeGrid {
  TimeSpan span;
  bool steps_capped = false;  // the default step count reached kMaxDefaultSteps
  bool log_time = false;      // the plot's time axis is logarithmic
};

// Sets ti.t_end and ti.steps: the options' values, else defaults from the reduced model's
// dynamics (suggest_time_span): the span its transient needs, 20 steps per period of its fastest
// term that matters. A chirp, or a model whose response does not settle, keeps the band's: 5
// periods of its lowest frequency (or the chirp's, if lower), 20 steps per period of its highest
// (or the chirp's, if higher).
TimeGrid choose_time_grid(const SimulateOptions& o, const RunInfo& run, const ReducedModel& reduced,
                          const InputSignal& input, TimeIntegrationOptions& ti) {
  TimeGrid grid;
  grid.span = suggest_time_span(reduced, input.kind, run.f_min_hz, run.f_max_hz);
  TimeSpan& span = grid.span;
  if (input.kind == InputSignal::Kind::Chirp) {
    const double f_low = std::min({run.f_min_hz, input.f0_hz, input.f1_hz});
    span.f_fast_hz = std::max({run.f_max_hz, input.f0_hz, input.f1_hz});
    span.t_end = 5.0 / f_low;
  }
  // An explicit value (even an invalid one, which validate() then names) wins over the default.
  ti.t_end = o.t_end != 0.0 ? o.t_end : span.t_end;
  if (o.steps != 0) {
    ti.steps = o.steps;
  } else {
    const double wanted = std::ceil(20.0 * span.f_fast_hz * ti.t_end);
    grid.steps_capped = !(wanted <= static_cast<double>(SimulateOptions::kMaxDefaultSteps));
    ti.steps = grid.steps_capped ? SimulateOptions::kMaxDefaultSteps
                                 : std::max<Index>(200, static_cast<Index>(wanted));
  }
  // A log-time axis where the dynamics span more than three decades: 1 / (2 pi f_fast) to t_end.
  grid.log_time =
      o.time_axis == "log" || (o.time_axis == "auto" && ti.t_end * kTwoPi * span.f_fast_hz > 1e3);
  ti.validate();
  return grid;
}

// A finished simulation: its setup, both responses and their difference.
struct Simulation {
  InputSignal input;
  TimeIntegrationOptions ti;
  TimeGrid grid;
  TimeResponse y, yr;  // full, reduced
  OutputError error;
  Index full_order = 0, reduced_order = 0;
};

// time_response.csv: t, the full outputs y1..yp, the reduced outputs yr1..yrp.
std::string time_response_csv(const Simulation& s) {
  const Index p = s.y.y.rows();
  std::string csv = "t";
  for (Index i = 1; i <= p; ++i) csv += fmt::format(",y{}", i);
  for (Index i = 1; i <= p; ++i) csv += fmt::format(",yr{}", i);
  csv += "\n";
  for (Index k = 0; k < s.y.y.cols(); ++k) {
    csv += fmt::format("{:.17g}", s.y.t[static_cast<std::size_t>(k)]);
    for (Index i = 0; i < p; ++i) csv += fmt::format(",{:.17g}", s.y.y(i, k));
    for (Index i = 0; i < p; ++i) csv += fmt::format(",{:.17g}", s.yr.y(i, k));
    csv += "\n";
  }
  return csv;
}

// time_error.json: the input, the scheme, how the span was chosen, the output error's norms and
// the cost of both simulations.
nlohmann::json time_error_json(const Simulation& s, const SimulateOptions& o) {
  auto finite_or_null = [](double x) -> nlohmann::json {
    return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr);
  };
  const OutputError& e = s.error;
  const TimeSpan& span = s.grid.span;
  nlohmann::json j;
  j["input"] = {{"kind", to_string(s.input.kind)},
                {"input_index", s.input.input},
                {"amplitude", s.input.amplitude}};
  if (s.input.kind == InputSignal::Kind::Chirp) {
    j["input"]["chirp"] = {{"f0_hz", s.input.f0_hz}, {"f1_hz", s.input.f1_hz}, {"sweep", "linear"}};
  }
  j["scheme"] = to_string(s.ti.scheme);
  j["scheme_description"] = s.y.scheme;
  j["rho_inf"] = s.ti.rho_inf;
  j["t_end"] = s.ti.t_end;
  j["steps"] = s.ti.steps;
  j["dt"] = s.y.dt;
  j["steps_capped"] = s.grid.steps_capped;
  j["span"] = {
      {"t_end_default", o.t_end == 0.0}, {"from_poles", span.from_poles},
      {"tau_slow", span.tau_slow},       {"f_fast_hz", span.f_fast_hz},
      {"reason", span.reason},           {"time_axis", s.grid.log_time ? "log" : "linear"}};
  j["error"] = {{"l2", e.l2},
                {"max", e.max},
                {"t_at_max", e.t_max},
                {"relative_l2", finite_or_null(e.relative_l2)},
                {"relative_max", finite_or_null(e.relative_max)},
                {"relative_defined", e.relative_defined},
                {"y_l2", e.y_l2},
                {"y_max", e.y_max},
                {"norms",
                 "l2: sqrt(int ||e(t)||_2^2 dt), trapezoidal rule; max: max over "
                 "samples and outputs of |e_i(t_k)|"}};
  j["full"] = response_json(s.y);
  j["full"]["N"] = s.full_order;
  j["reduced"] = response_json(s.yr);
  j["reduced"]["n"] = s.reduced_order;
  return j;
}

// The output-error line always; with it, unless quiet, the setup, the cost and the files.
void print_report(const Simulation& s, const SimulateOptions& o, bool quiet) {
  const OutputError& e = s.error;
  if (s.grid.steps_capped && !quiet) {
    fmt::print(
        "note: default steps capped at {} (20 steps per period of {:g} Hz would need "
        "more); pass --steps to resolve the highest frequency\n",
        SimulateOptions::kMaxDefaultSteps, s.grid.span.f_fast_hz);
  }
  if (!quiet) {
    fmt::print("{} input{}, t in [0, {:g}] s, {} steps of {:.3e} s, {}\n", to_string(s.input.kind),
               s.input.input < 0 ? std::string(" (all inputs)") : fmt::format(" {}", s.input.input),
               s.ti.t_end, s.ti.steps, s.y.dt, s.y.scheme);
    if (o.t_end == 0.0) fmt::print("span: {}\n", s.grid.span.reason);
    fmt::print("full    N = {:>7}  {:.3f} s  {} factorisations  {} solves\n", s.full_order,
               s.y.seconds, s.y.factorizations, s.y.solves);
    fmt::print("reduced n = {:>7}  {:.3f} s  {} factorisations  {} solves\n", s.reduced_order,
               s.yr.seconds, s.yr.factorizations, s.yr.solves);
  }
  fmt::print(
      "output error y - yr: L2 {:.3e} (relative {:.3e}), max {:.3e} (relative {:.3e}) "
      "at t = {:.4g} s\n",
      e.l2, e.relative_l2, e.max, e.relative_max, e.t_max);
  if (!quiet) {
    fmt::print("outputs in {} and {}\n", (o.run_dir / "time_response.csv").string(),
               (o.run_dir / "time_error.json").string());
  }
}

// time_response.png/.svg. A missing gnuplot is a note, a failing one a warning: the numbers are
// all in the CSV.
void plot_simulation(const Simulation& s, const fs::path& run_dir, bool quiet) {
  try {
    plot_time_response(run_dir, s.y.y.rows(),
                       fmt::format("{} response: full N = {}, reduced n = {}; max |y - yr| = "
                                   "{:.3e} (relative {:.3e})",
                                   to_string(s.input.kind), s.full_order, s.reduced_order,
                                   s.error.max, s.error.relative_max),
                       s.grid.log_time);
    if (!quiet) fmt::print("plot: {}\n", (run_dir / "time_response.png").string());
  } catch (const GnuplotNotFound& err) {
    if (!quiet) fmt::print("note: {}\n", err.what());
  } catch (const Error& err) {
    fmt::print(stderr, "ecmor: warning: time_response plot not rendered: {}\n", err.what());
  }
}

}  // namespace

int simulate(const SimulateOptions& o, const CommonOptions& common) {
  return guarded([&] {
    const RunInfo run = read_run(o.run_dir);
    Simulation s;
    s.input = input_signal(o, run);
    s.ti = integration_options(o);
    s.input.validate();

    const Model model = load_model(run.model);
    const ReducedModel reduced = read_reduced_model(o.run_dir);
    s.grid = choose_time_grid(o, run, reduced, s.input, s.ti);
    auto solver = make_shifted_solver(model);
    s.y = simulate(model, *solver, s.input, s.ti);
    s.yr = simulate(reduced, s.input, s.ti);
    s.error = output_error(s.y, s.yr);
    s.full_order = size_of(model);
    s.reduced_order = size_of(reduced);

    write_text_atomically(o.run_dir / "time_response.csv", time_response_csv(s));
    write_text_atomically(o.run_dir / "time_error.json", time_error_json(s, o).dump(2) + "\n");
    print_report(s, o, common.quiet);
    if (!common.no_plot) plot_simulation(s, o.run_dir, common.quiet);
    return 0;
  });
}

}  // namespace ecmor::app
