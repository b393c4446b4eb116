// `ecmor bench`: the same configured reductions over a ladder of tolerances, one table of order
// reached, errors, times and counters per run. Every run goes through run_reduction exactly as
// `ecmor reduce` would (its outputs land in <output>/runs/<config>_tol<t>/), so a benchmark number
// is always the number a user gets.
#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "commands.hpp"
#include "ecmor/base/atomic_file.hpp"
#include "ecmor/strategies/config.hpp"
#include "ecmor/base/error.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/plugin/registry.hpp"
#include "ecmor/strategies/driver.hpp"
#include "signals.hpp"
#include "pareto.hpp"
#include "plot.hpp"

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
  /// H-infinity norm of the error system and its scope ("all frequencies": dense level-set
  /// method, "band": sampled supremum); see RunSummary::hinf_error.
  double hinf_error = 0.0;
  std::string hinf_scope;
};


// Quiet during a run (one progress line when it ends); stops the run on SIGINT/SIGTERM.
class Progress final : public RunObserver {
 public:
  bool on_iteration(const IterationRecord&) override { return !stop_signalled(); }
  bool stop_requested() override { return stop_signalled(); }
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
          {"peak_memory_mb", r.peak_memory_mb},
          {"hinf_error", r.hinf_error},
          {"hinf_scope", r.hinf_scope}};
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
      "reducer_sparse_share,sparse_seconds,factorizations,solves,reducer_factorizations,reducer_"
      "solves,"
      "reducer_calls,iterations,peak_memory_mb,hinf_error,hinf_scope,message\n";
  for (const BenchRow& r : rows) {
    out += fmt::format(
        "{},{},{},{},{},{:g},{},{},{},{:.6e},{:.6e},{:.6e},{},{:.4f},{:.4f},{:.4f},{:.3f},{:.4f},{}"
        ",{},"
        "{},{},{},{},{:.1f},{:.6e},{},{}\n",
        csv_field(r.config), r.model, r.n_full, r.reducer, r.strategy, r.tolerance, r.termination,
        r.met ? 1 : 0, r.order, r.band_error, r.verified_error, r.f_peak_hz, r.stable ? 1 : 0,
        r.seconds, r.reducer_seconds, r.full_response_seconds, r.reducer_sparse_share,
        r.sparse_seconds, r.factorizations, r.solves, r.reducer_factorizations, r.reducer_solves,
        r.reducer_calls, r.iterations, r.peak_memory_mb, r.hinf_error, r.hinf_scope,
        csv_field(r.message));
  }
  return out;
}

std::string to_markdown(const std::vector<BenchRow>& rows) {
  std::string out =
      "| model | N | reducer | strategy | tolerance | result | order | verified error | "
      "H∞ error (abs.) | total s | reducer s | full response s | sparse s (all threads) | "
      "sparse share of reducer | factorisations (reducer) |\n"
      "|---|---:|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const BenchRow& r : rows) {
    const std::string result = r.met ? std::string("met") : r.termination;
    // "(band)": the sampled band supremum, not the norm over all frequencies.
    const std::string hinf =
        r.order > 0 ? fmt::format("{:.2e}{}", r.hinf_error, r.hinf_scope == "band" ? " (band)" : "")
                    : std::string("-");
    out += fmt::format(
        "| {} | {} | {} | {} | {:g} | {} | {} | {:.2e} | {} | {:.2f} | {:.3f} | "
        "{:.2f} | {:.2f} | {:.0f}% | {} ({}) |\n",
        r.model, r.n_full, r.reducer, r.strategy, r.tolerance, result,
        r.order > 0 ? std::to_string(r.order) : std::string("-"), r.verified_error, hinf, r.seconds,
        r.reducer_seconds, r.full_response_seconds, r.sparse_seconds,
        100.0 * r.reducer_sparse_share, r.factorizations, r.reducer_factorizations);
  }
  return out;
}

// How a run shows on the charts. Failed: the run threw, the strategy reported `failed` (which
// includes a model failing its independent re-check), or it left no model with a finite error.
std::string chart_status(const BenchRow& r) {
  if (r.termination == "error" || r.termination == "failed" || r.order <= 0 ||
      !std::isfinite(r.verified_error)) {
    return "failed";
  }
  return r.met ? "met" : "missed";
}

// The series a run belongs to: its method, reducer / strategy. The charts draw one panel per model
// (a point of one model is no trade-off against another's), and a method keeps its colour and
// marker in every panel.
std::vector<std::string> chart_labels(const std::vector<BenchRow>& rows) {
  std::vector<std::string> labels;
  for (const BenchRow& r : rows) labels.push_back(r.reducer + " / " + r.strategy);
  return labels;
}

// Colour and marker of series k (1-based): ten colours that stay apart in print and for the
// common colour-vision deficiencies (Tableau 10) and seven filled or open markers, so that no two
// of the first 70 series look alike.
std::string series_style(std::size_t k) {
  static const char* colours[] = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                  "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
  static const int markers[] = {7, 5, 9, 11, 13, 4, 8};
  const std::size_t i = k - 1;
  return fmt::format("pt {} lc rgb '{}'", markers[i % 7], colours[i % 10]);
}

// Gnuplot's number syntax for a finite double.
std::string gp_number(double x) { return fmt::format("{}", x); }

// bench_chart.csv and the two charts. The numbers are bench.csv's, with the same rounding, so a
// chart row can be matched to its table row as text. The Pareto front is over (total seconds,
// verified error) of the runs that did not fail, one front per model.
class BenchCharts {
 public:
  BenchCharts(std::filesystem::path out, bool quiet) : m_out(std::move(out)), m_quiet(quiet) {}

  void write(const std::vector<BenchRow>& rows) {
    const std::vector<std::string> labels = chart_labels(rows);
    std::vector<std::string> series;  // distinct labels in order of appearance
    std::vector<std::size_t> series_of;
    std::vector<TradeoffPoint> points;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      auto it = std::find(series.begin(), series.end(), labels[i]);
      if (it == series.end()) it = series.insert(series.end(), labels[i]);
      series_of.push_back(static_cast<std::size_t>(it - series.begin()) + 1);
      points.push_back(
          {rows[i].seconds, rows[i].verified_error, chart_status(rows[i]) != "failed"});
    }
    // One front per model: a fast run on a small model is no trade-off against a slow one on a
    // large model.
    std::vector<bool> front(rows.size(), false);
    std::set<std::string> models;
    for (const BenchRow& r : rows) models.insert(r.model);
    for (const std::string& model : models) {
      std::vector<std::size_t> members;
      std::vector<TradeoffPoint> subset;
      for (std::size_t i = 0; i < rows.size(); ++i) {
        if (rows[i].model != model) continue;
        members.push_back(i);
        subset.push_back(points[i]);
      }
      const std::vector<bool> f = pareto_front(subset);
      for (std::size_t k = 0; k < members.size(); ++k) front[members[k]] = f[k];
    }

    std::string csv =
        "run,series,label,model,reducer,strategy,tolerance,status,order,verified_band_error,"
        "seconds,reducer_seconds,pareto\n";
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const BenchRow& r = rows[i];
      csv += fmt::format("{},{},{},{},{},{},{:g},{},{},{:.6e},{:.4f},{:.4f},{}\n", i + 1,
                         series_of[i], csv_field(labels[i]), csv_field(r.model),
                         csv_field(r.reducer), csv_field(r.strategy), r.tolerance, chart_status(r),
                         r.order, r.verified_error, r.seconds, r.reducer_seconds, front[i] ? 1 : 0);
    }
    write_text_atomically(m_out / "bench_chart.csv", csv);

    // The models, one panel each, in order of first appearance.
    std::vector<std::string> models_in_order;
    for (const BenchRow& r : rows)
      if (std::find(models_in_order.begin(), models_in_order.end(), r.model) ==
          models_in_order.end())
        models_in_order.push_back(r.model);

    // Where failed runs are drawn: a row above every real value (they have no error to plot),
    // and at a positive time on the log axis even when they failed before the clock mattered.
    double top = 0.0, min_seconds = 0.0, max_seconds = 0.0, bottom = 0.0;
    Index max_order = 0;
    std::set<double> tolerances;
    std::size_t failed = 0, missed = 0, on_front = 0;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      tolerances.insert(rows[i].tolerance);
      top = std::max(top, rows[i].tolerance);
      bottom = bottom == 0.0 ? rows[i].tolerance : std::min(bottom, rows[i].tolerance);
      const std::string status = chart_status(rows[i]);
      failed += status == "failed" ? 1 : 0;
      missed += status == "missed" ? 1 : 0;
      on_front += front[i] ? 1 : 0;
      if (status == "failed") continue;
      max_order = std::max(max_order, rows[i].order);
      if (rows[i].verified_error > 0.0) {
        top = std::max(top, rows[i].verified_error);
        bottom = std::min(bottom, rows[i].verified_error);
      }
      if (rows[i].seconds > 0.0) {
        if (min_seconds == 0.0 || rows[i].seconds < min_seconds) min_seconds = rows[i].seconds;
        max_seconds = std::max(max_seconds, rows[i].seconds);
      }
    }
    const double fail_y = top > 0.0 ? std::pow(10.0, std::ceil(std::log10(top)) + 1.0) : 1.0;
    const double fail_x = min_seconds > 0.0 ? min_seconds : 1e-2;

    // Failed runs are stacked upwards from fail_y (0.3 decades apart, ranked within their panel)
    // so that their labels never overlap, each a red cross with "label tol t" beside it.
    auto failed_y = [&](std::size_t rank) {
      return fail_y * std::pow(10.0, 0.3 * static_cast<double>(rank));
    };
    std::size_t most_failed_in_a_panel = 0;
    for (const std::string& model : models_in_order) {
      std::size_t n = 0;
      for (const BenchRow& r : rows) n += r.model == model && chart_status(r) == "failed" ? 1 : 0;
      most_failed_in_a_panel = std::max(most_failed_in_a_panel, n);
    }
    // One panel's plot: the model's runs per method, its Pareto front and missed runs, its failed
    // runs as labels, the tolerance ladder. `x` is the gnuplot expression of the abscissa for a
    // non-failed run, `failed_x` the abscissa of failed run i. The key is drawn once, in a panel of
    // its own (keys_only), listing every method in the bench.
    auto plot_command = [&](const std::string& model, const std::string& x,
                            const std::function<double(std::size_t)>& failed_x, bool with_front) {
      const std::string mine = fmt::format("strcol(4) eq {}", gnuplot_string(model));
      std::string labels_cmd = "unset label\n";
      std::size_t rank = 0;
      for (std::size_t i = 0; i < rows.size(); ++i) {
        if (rows[i].model != model || chart_status(rows[i]) != "failed") continue;
        labels_cmd += fmt::format(
            "set label {} {} at {},{} left point pt 2 ps 2 lc rgb '#d62728' offset char 1.2,0 "
            "tc rgb '#d62728' front\n",
            rank + 1, gnuplot_string(fmt::format("{} tol {:g}", labels[i], rows[i].tolerance)),
            gp_number(failed_x(i)), gp_number(failed_y(rank)));
        ++rank;
      }
      std::vector<std::string> parts;
      for (std::size_t k = 0; k < series.size(); ++k) {
        bool drawable = false;
        for (std::size_t i = 0; i < rows.size(); ++i) {
          drawable = drawable || (series_of[i] == k + 1 && rows[i].model == model &&
                                  chart_status(rows[i]) != "failed");
        }
        if (!drawable) continue;
        parts.push_back(fmt::format(
            "'bench_chart.csv' skip 1 using (($2 == {0} && {1} && strcol(8) ne 'failed') ? {2} : "
            "NaN):10 with linespoints lw 1.5 {3} ps 1.2 notitle",
            k + 1, mine, x, series_style(k + 1)));
      }
      if (with_front && on_front > 0) {
        parts.push_back(fmt::format(
            "'bench_chart.csv' skip 1 using (($13 == 1 && {}) ? {} : NaN):10 with points pt 6 "
            "ps 2.5 lw 2 lc rgb '#000000' notitle",
            mine, x));
      }
      if (missed > 0) {
        parts.push_back(fmt::format(
            "'bench_chart.csv' skip 1 using ((strcol(8) eq 'missed' && {}) ? {} : NaN):10 with "
            "points pt 3 ps 1.8 lw 1.5 lc rgb '#ff7f0e' notitle",
            mine, x));
      }
      for (double t : tolerances)
        parts.push_back(fmt::format("{} with lines dt 2 lw 1 lc rgb '#555555' notitle",
                                    gp_number(t)));
      std::string cmd = labels_cmd + fmt::format("set title {} noenhanced\nplot ",
                                                 gnuplot_string(model));
      for (std::size_t i = 0; i < parts.size(); ++i) {
        cmd += (i > 0 ? ", \\\n     " : "") + parts[i];
      }
      return cmd + "\n";
    };
    auto keys_only = [&](bool with_front) {
      std::vector<std::string> parts;
      for (std::size_t k = 0; k < series.size(); ++k)
        parts.push_back(fmt::format("NaN with linespoints lw 1.5 {} ps 1.2 title {}",
                                    series_style(k + 1), gnuplot_string(series[k])));
      if (with_front && on_front > 0)
        parts.push_back("NaN with points pt 6 ps 2.5 lw 2 lc rgb '#000000' title 'Pareto front "
                        "(time, error; per model)'");
      if (missed > 0)
        parts.push_back("NaN with points pt 3 ps 1.8 lw 1.5 lc rgb '#ff7f0e' title 'target "
                        "missed (model kept)'");
      if (failed > 0)
        parts.push_back(fmt::format(
            "NaN with points pt 2 ps 2 lc rgb '#d62728' title {}",
            gnuplot_string(fmt::format("FAILED ({} run{}): crosses at the top, no error", failed,
                                       failed == 1 ? "" : "s"))));
      parts.push_back("NaN with lines dt 2 lw 1 lc rgb '#555555' title 'tolerance ladder'");
      std::string cmd =
          "unset label\nunset title\nunset border\nunset tics\nunset xlabel\nunset ylabel\n"
          "unset grid\nset key center center horizontal maxrows 3 noenhanced\nset xrange [0:1]\n"
          "set yrange [0:1]\n"
          "unset logscale\nplot ";
      for (std::size_t i = 0; i < parts.size(); ++i) {
        cmd += (i > 0 ? ", \\\n     " : "") + parts[i];
      }
      return cmd + "\n";
    };
    // Small multiples: one panel per model on shared axes, up to three per row, and below them
    // one key for all panels, laid out by hand (a layout grid would give the key a whole row).
    const std::size_t columns = std::min<std::size_t>(models_in_order.size(), 3);
    const std::size_t rows_of_panels = (models_in_order.size() + columns - 1) / columns;
    const int width = 1200;
    const int height = static_cast<int>(std::max<std::size_t>(650, 400 * rows_of_panels + 170));
    const double key_fraction = 150.0 / height;  // the key's strip at the bottom
    const double title_fraction = 30.0 / height;
    const double panel_h = (1.0 - key_fraction - title_fraction) / static_cast<double>(rows_of_panels);
    const double panel_w = 1.0 / static_cast<double>(columns);
    const double y_low = bottom > 0.0 ? bottom / 3.0 : 1e-16;
    const double y_high = 3.0 * failed_y(most_failed_in_a_panel > 0 ? most_failed_in_a_panel - 1 : 0);
    auto chart = [&](const std::string& title, const std::string& axes, const std::string& x,
                     const std::function<double(std::size_t)>& failed_x, bool with_front) {
      std::string body = fmt::format("set multiplot title {} noenhanced\n", gnuplot_string(title));
      for (std::size_t m = 0; m < models_in_order.size(); ++m) {
        const std::size_t row = m / columns, column = m % columns;
        body += fmt::format(
            "set origin {},{}\nset size {},{}\n"
            "set logscale y\nset grid\nset border\nset tics\nunset key\nset format y '%g'\n"
            "set yrange [{}:{}]\nset ylabel 'verified band error'\n",
            gp_number(panel_w * static_cast<double>(column)),
            gp_number(key_fraction + panel_h * static_cast<double>(rows_of_panels - 1 - row)),
            gp_number(panel_w), gp_number(panel_h), gp_number(y_low), gp_number(y_high));
        body += axes + plot_command(models_in_order[m], x, failed_x, with_front);
      }
      body += fmt::format("set origin 0,0\nset size 1,{}\n", gp_number(key_fraction)) +
              keys_only(with_front) + "unset multiplot\n";
      return body;
    };
    std::vector<PlotScript> scripts;
    const double x_low = fail_x / 1.5;
    const double x_high = std::max(max_seconds, fail_x) * 1.5;
    scripts.push_back(
        {"bench_time_error",
         chart("ecmor bench: run time vs achieved band error, one panel per model (circled: "
               "Pareto front)",
               fmt::format("set logscale x\nset format x '%g'\nset xrange [{}:{}]\n"
                           "set xlabel 'total run time [s]'\n",
                           gp_number(x_low), gp_number(x_high)),
               "$11",
               [&](std::size_t i) { return rows[i].seconds > 0.0 ? rows[i].seconds : fail_x; },
               true),
         width, height});
    scripts.push_back(
        {"bench_order_error",
         chart("ecmor bench: reduced order vs achieved band error, one panel per model",
               fmt::format("unset logscale x\nset format x '%g'\nset xrange [0:{}]\n"
                           "set xlabel 'reduced order'\n",
                           std::max<Index>(1, max_order + max_order / 10 + 1)),
               "$9", [&](std::size_t i) { return static_cast<double>(rows[i].order); }, false),
         width, height});
    try {
      render_plots(m_out, scripts, PlotFormat::Both);
    } catch (const GnuplotNotFound& e) {
      if (!m_noted && !m_quiet) fmt::print("note: {}\n", e.what());
      m_noted = true;
    } catch (const Error& e) {
      if (!m_noted) fmt::print(stderr, "ecmor: warning: bench charts not rendered: {}\n", e.what());
      m_noted = true;
    }
  }

 private:
  std::filesystem::path m_out;
  bool m_quiet;
  bool m_noted = false;  // one note per bench, not one per run
};

/// One configuration of the bench: run over the tolerance ladder under `name` (the run
/// directories' stem).
struct Job {
  RunConfig config;
  std::string name;
};

// Portfolio configs become one job per member (one chart series each) unless --portfolio-as-one;
// --all-reducers makes one job per loaded reducer that accepts the model's kind.
std::vector<Job> expand_jobs(const std::vector<RunConfig>& configs, const BenchOptions& options,
                             const CommonOptions& common) {
  std::vector<Job> jobs;
  auto plain = [](const RunConfig& base, const PortfolioMember& m) {
    RunConfig c = base;
    c.portfolio.clear();
    c.reducer_name = m.reducer_name;
    c.reducer_params = m.reducer_params;
    c.strategy_name = m.strategy_name;
    c.strategy_params = m.strategy_params;
    return c;
  };
  for (const RunConfig& base : configs) {
    const std::string stem = base.source.stem().string();
    if (options.all_reducers) {
      Registry registry;
      load_plugins(registry, common, base.plugins);
      // The kind as load_model decides it (a directory's files or a .mat file's variables).
      const bool second_order = kind_of(load_model(base.model)) == ModelKind::SecondOrder;
      for (const Registry::Entry& e : registry.entries()) {
        if (second_order ? !e.info.second_order : !e.info.descriptor) continue;
        PortfolioMember m;
        m.reducer_name = e.info.name;
        m.reducer_params = ParameterMap("reducer '" + e.info.name + "'");
        m.strategy_name = "grow_order";
        m.strategy_params = base.strategy_name == "grow_order"
                                ? base.strategy_params
                                : ParameterMap("strategy 'grow_order'");
        jobs.push_back({plain(base, m), stem + "_" + e.info.name});
      }
    } else if (!base.portfolio.empty() && !options.portfolio_as_one) {
      for (const PortfolioMember& m : base.portfolio) {
        jobs.push_back({plain(base, m), stem + "_" + m.reducer_name + "_" + m.strategy_name});
      }
    } else {
      jobs.push_back({base, stem});
    }
  }
  if (jobs.empty()) throw ConfigError("ecmor bench: no loaded reducer accepts the models given");
  return jobs;
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
    std::vector<RunConfig> loaded;
    for (const auto& path : options.configs) loaded.push_back(load_run_config(path));
    const std::vector<Job> configs = expand_jobs(loaded, options, common);
    install_stop_signals();

    std::vector<BenchRow> rows;
    const std::filesystem::path out = std::filesystem::absolute(options.output_dir);
    std::size_t total = 0;
    total = configs.size() * std::max<std::size_t>(options.tolerances.size(), 1);
    std::size_t done = 0;
    std::set<std::string> used_names;
    bool all_met = true;
    const auto start = std::chrono::steady_clock::now();
    auto elapsed = [&] {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    BenchCharts charts(out, common.quiet);
    for (const Job& job : configs) {
      const RunConfig& base = job.config;
      std::vector<double> ladder = options.tolerances;
      if (ladder.empty()) ladder.push_back(base.tolerance);
      for (double tol : ladder) {
        if (stop_signalled()) break;
        RunConfig config = base;
        config.tolerance = tol;
        if (options.time_limit_s > 0.0) config.time_limit_s = options.time_limit_s;
        // One directory per run: configs with the same file name in different folders, or a
        // tolerance given twice, get a numbered suffix instead of overwriting a run's outputs.
        std::string run_name = job.name + "_tol" + tol_tag(tol);
        for (int k = 2; used_names.count(run_name) > 0; ++k) {
          run_name = job.name + "_tol" + tol_tag(tol) + "_" + std::to_string(k);
        }
        used_names.insert(run_name);
        config.output_dir = out / "runs" / run_name;
        BenchRow row;
        row.config = base.source.string();
        row.model = base.model.path.filename().string();
        row.reducer = base.reducer_name;
        row.strategy = base.strategy_name;
        row.tolerance = tol;
        ++done;
        // The elapsed time since the bench started shows while a run goes on.
        fmt::print("[{}/{} {:.1f} s] {} ({} / {}) tolerance {:g} ... ", done, total, elapsed(),
                   row.model, row.reducer, row.strategy, tol);
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
          row.hinf_error = s.hinf_error;
          row.hinf_scope = s.hinf_scope;
          fmt::print("{} order {} error {:.2e}, {:.2f} s (reducer {:.3f} s), {:.1f} s elapsed\n",
                     row.met ? "met," : row.termination + ",", row.order, row.verified_error,
                     row.seconds, row.reducer_seconds, elapsed());
        } catch (const std::exception& e) {
          // A failing run is a row of the table, not a missing one.
          row.termination = "error";
          row.message = e.what();
          fmt::print("error: {} ({:.1f} s elapsed)\n", e.what(), elapsed());
        }
        all_met = all_met && row.met;
        rows.push_back(row);
        // Rewritten after every run, so an interrupted bench keeps what it measured.
        write_text_atomically(out / "bench.csv", to_csv(rows));
        nlohmann::json j = nlohmann::json::array();
        for (const BenchRow& r : rows) j.push_back(to_json(r));
        write_text_atomically(out / "bench.json", j.dump(2) + "\n");
        write_text_atomically(out / "bench.md", to_markdown(rows));
        charts.write(rows);
      }
    }
    const double seconds = elapsed();
    fmt::print("\n{}\n{} runs in {:.1f} s; results in {}\n", to_markdown(rows), rows.size(),
               seconds, out.string());
    if (stop_signalled()) return 130;
    return all_met ? 0 : 2;
  });
}

}  // namespace ecmor::app
