// The reports of `ecmor bench`. The tables carry every measured number; the charts put one panel
// per model (a run on one model is no trade-off against a run on another), with the Pareto front
// over (total seconds, verified error) of the runs that did not fail.
#include "bench_report.hpp"

#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>
#include <set>

#include "ecmor/base/atomic_file.hpp"
#include "ecmor/base/error.hpp"
#include "gnuplot.hpp"
#include "pareto.hpp"

namespace ecmor::app {
namespace {

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
          {"band_error_seconds", r.band_error_seconds},
          {"reference_seconds", r.reference_seconds},
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
      "band_error_seconds,reference_seconds,reducer_sparse_share,sparse_seconds,factorizations,"
      "solves,reducer_factorizations,reducer_solves,reducer_calls,iterations,peak_memory_mb,"
      "hinf_error,hinf_scope,message\n";
  for (const BenchRow& r : rows) {
    out += fmt::format(
        "{},{},{},{},{},{:g},{},{},{},{:.6e},{:.6e},{:.6e},{},{:.4f},{:.4f},{:.4f},{:.4f},{:.4f},"
        "{:.3f},{:.4f},{}"
        ",{},"
        "{},{},{},{},{:.1f},{:.6e},{},{}\n",
        csv_field(r.config), r.model, r.n_full, r.reducer, r.strategy, r.tolerance, r.termination,
        r.met ? 1 : 0, r.order, r.band_error, r.verified_error, r.f_peak_hz, r.stable ? 1 : 0,
        r.seconds, r.reducer_seconds, r.full_response_seconds, r.band_error_seconds,
        r.reference_seconds, r.reducer_sparse_share, r.sparse_seconds, r.factorizations, r.solves,
        r.reducer_factorizations, r.reducer_solves, r.reducer_calls, r.iterations, r.peak_memory_mb,
        r.hinf_error, r.hinf_scope, csv_field(r.message));
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

// The charts' height: 400 pixels per row of panels and 170 for the title and the key, at least 650.
int chart_height(std::size_t rows_of_panels) {
  return static_cast<int>(std::max<std::size_t>(650, 400 * rows_of_panels + 170));
}

// The abscissa of failed run i, which has no point of its own.
using FailedX = std::function<double(std::size_t)>;

// The charts of a bench: bench_chart.csv and the two gnuplot scripts. The numbers are bench.csv's,
// with the same rounding, so a chart row can be matched to its table row as text.
class BenchCharts {
 public:
  explicit BenchCharts(const std::vector<BenchRow>& rows) : m_rows(rows) {
    m_labels = chart_labels(rows);
    for (std::size_t i = 0; i < rows.size(); ++i) {
      m_status.push_back(chart_status(rows[i]));
      auto it = std::find(m_series.begin(), m_series.end(), m_labels[i]);
      if (it == m_series.end()) it = m_series.insert(m_series.end(), m_labels[i]);
      m_series_of.push_back(static_cast<std::size_t>(it - m_series.begin()) + 1);
      if (std::find(m_models.begin(), m_models.end(), rows[i].model) == m_models.end())
        m_models.push_back(rows[i].model);
    }
    find_fronts();
    find_ranges();
  }

  std::string csv() const;
  std::vector<PlotScript> scripts() const;

 private:
  void find_fronts();
  void find_ranges();
  double failed_y(std::size_t rank) const;
  std::string failed_labels(const std::string& model, const FailedX& failed_x) const;
  std::string panel_plot(const std::string& model, const std::string& x, const FailedX& failed_x,
                         bool with_front) const;
  std::string key_panel(bool with_front) const;
  std::string chart(const std::string& title, const std::string& axes, const std::string& x,
                    const FailedX& failed_x, bool with_front) const;

  const std::vector<BenchRow>& m_rows;
  std::vector<std::string> m_labels;     // per run: its method, "reducer / strategy"
  std::vector<std::string> m_status;     // per run: chart_status
  std::vector<std::string> m_series;     // the distinct labels, in order of appearance
  std::vector<std::size_t> m_series_of;  // per run: its series, 1-based
  std::vector<std::string> m_models;     // one panel each, in order of first appearance
  std::vector<bool> m_front;             // per run: on its model's Pareto front
  std::set<double> m_tolerances;
  std::size_t m_failed = 0, m_missed = 0, m_on_front = 0, m_most_failed_in_a_panel = 0;
  double m_top = 0.0, m_bottom = 0.0, m_min_seconds = 0.0, m_max_seconds = 0.0;
  Index m_max_order = 0;
  double m_fail_x = 0.0, m_fail_y = 0.0;  // where failed runs are drawn
};

// One front per model: a fast run on a small model is no trade-off against a slow one on a large
// model.
void BenchCharts::find_fronts() {
  m_front.assign(m_rows.size(), false);
  for (const std::string& model : m_models) {
    std::vector<std::size_t> members;
    std::vector<TradeoffPoint> subset;
    for (std::size_t i = 0; i < m_rows.size(); ++i) {
      if (m_rows[i].model != model) continue;
      members.push_back(i);
      subset.push_back({m_rows[i].seconds, m_rows[i].verified_error, m_status[i] != "failed"});
    }
    const std::vector<bool> f = pareto_front(subset);
    for (std::size_t k = 0; k < members.size(); ++k) m_front[members[k]] = f[k];
  }
}

// The axes' ranges and the counts the key reports. Failed runs are drawn in a row above every
// real value (they have no error to plot), and at a positive time on the log axis even when they
// failed before the clock mattered.
void BenchCharts::find_ranges() {
  for (std::size_t i = 0; i < m_rows.size(); ++i) {
    const BenchRow& r = m_rows[i];
    m_tolerances.insert(r.tolerance);
    m_top = std::max(m_top, r.tolerance);
    m_bottom = m_bottom == 0.0 ? r.tolerance : std::min(m_bottom, r.tolerance);
    m_failed += m_status[i] == "failed" ? 1 : 0;
    m_missed += m_status[i] == "missed" ? 1 : 0;
    m_on_front += m_front[i] ? 1 : 0;
    if (m_status[i] == "failed") continue;
    m_max_order = std::max(m_max_order, r.order);
    if (r.verified_error > 0.0) {
      m_top = std::max(m_top, r.verified_error);
      m_bottom = std::min(m_bottom, r.verified_error);
    }
    if (r.seconds > 0.0) {
      if (m_min_seconds == 0.0 || r.seconds < m_min_seconds) m_min_seconds = r.seconds;
      m_max_seconds = std::max(m_max_seconds, r.seconds);
    }
  }
  m_fail_y = m_top > 0.0 ? std::pow(10.0, std::ceil(std::log10(m_top)) + 1.0) : 1.0;
  m_fail_x = m_min_seconds > 0.0 ? m_min_seconds : 1e-2;
  for (const std::string& model : m_models) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < m_rows.size(); ++i)
      n += m_rows[i].model == model && m_status[i] == "failed" ? 1 : 0;
    m_most_failed_in_a_panel = std::max(m_most_failed_in_a_panel, n);
  }
}

std::string BenchCharts::csv() const {
  std::string csv =
      "run,series,label,model,reducer,strategy,tolerance,status,order,verified_band_error,"
      "seconds,reducer_seconds,pareto\n";
  for (std::size_t i = 0; i < m_rows.size(); ++i) {
    const BenchRow& r = m_rows[i];
    csv += fmt::format("{},{},{},{},{},{},{:g},{},{},{:.6e},{:.4f},{:.4f},{}\n", i + 1,
                       m_series_of[i], csv_field(m_labels[i]), csv_field(r.model),
                       csv_field(r.reducer), csv_field(r.strategy), r.tolerance, m_status[i],
                       r.order, r.verified_error, r.seconds, r.reducer_seconds, m_front[i] ? 1 : 0);
  }
  return csv;
}

// Failed runs are stacked upwards from m_fail_y (0.3 decades apart, ranked within their panel)
// so that their labels never overlap.
double BenchCharts::failed_y(std::size_t rank) const {
  return m_fail_y * std::pow(10.0, 0.3 * static_cast<double>(rank));
}

// A model's failed runs, each a red cross with "label tol t" beside it.
std::string BenchCharts::failed_labels(const std::string& model, const FailedX& failed_x) const {
  std::string cmd = "unset label\n";
  std::size_t rank = 0;
  for (std::size_t i = 0; i < m_rows.size(); ++i) {
    if (m_rows[i].model != model || m_status[i] != "failed") continue;
    cmd += fmt::format(
        "set label {} {} at {},{} left point pt 2 ps 2 lc rgb '#d62728' offset char 1.2,0 "
        "tc rgb '#d62728' front\n",
        rank + 1, gnuplot_string(fmt::format("{} tol {:g}", m_labels[i], m_rows[i].tolerance)),
        gp_number(failed_x(i)), gp_number(failed_y(rank)));
    ++rank;
  }
  return cmd;
}

// One gnuplot plot command over the parts, one part per line.
std::string plot_of(const std::vector<std::string>& parts) {
  std::string cmd = "plot ";
  for (std::size_t i = 0; i < parts.size(); ++i) {
    cmd += (i > 0 ? ", \\\n     " : "") + parts[i];
  }
  return cmd + "\n";
}

// One panel's plot: the model's runs per method, its Pareto front and missed runs, its failed
// runs as labels, the tolerance ladder. `x` is the gnuplot expression of the abscissa for a
// non-failed run.
std::string BenchCharts::panel_plot(const std::string& model, const std::string& x,
                                    const FailedX& failed_x, bool with_front) const {
  const std::string mine = fmt::format("strcol(4) eq {}", gnuplot_string(model));
  std::vector<std::string> parts;
  for (std::size_t k = 0; k < m_series.size(); ++k) {
    bool drawable = false;
    for (std::size_t i = 0; i < m_rows.size(); ++i) {
      drawable = drawable ||
                 (m_series_of[i] == k + 1 && m_rows[i].model == model && m_status[i] != "failed");
    }
    if (!drawable) continue;
    parts.push_back(fmt::format(
        "'bench_chart.csv' skip 1 using (($2 == {0} && {1} && strcol(8) ne 'failed') ? {2} : "
        "NaN):10 with linespoints lw 1.5 {3} ps 1.2 notitle",
        k + 1, mine, x, series_style(k + 1)));
  }
  if (with_front && m_on_front > 0) {
    parts.push_back(fmt::format(
        "'bench_chart.csv' skip 1 using (($13 == 1 && {}) ? {} : NaN):10 with points pt 6 "
        "ps 2.5 lw 2 lc rgb '#000000' notitle",
        mine, x));
  }
  if (m_missed > 0) {
    parts.push_back(fmt::format(
        "'bench_chart.csv' skip 1 using ((strcol(8) eq 'missed' && {}) ? {} : NaN):10 with "
        "points pt 3 ps 1.8 lw 1.5 lc rgb '#ff7f0e' notitle",
        mine, x));
  }
  for (double t : m_tolerances)
    parts.push_back(fmt::format("{} with lines dt 2 lw 1 lc rgb '#555555' notitle", gp_number(t)));
  return failed_labels(model, failed_x) +
         fmt::format("set title {} noenhanced\n", gnuplot_string(model)) + plot_of(parts);
}

// The key, drawn once in a panel of its own, listing every method in the bench.
std::string BenchCharts::key_panel(bool with_front) const {
  std::vector<std::string> parts;
  for (std::size_t k = 0; k < m_series.size(); ++k)
    parts.push_back(fmt::format("NaN with linespoints lw 1.5 {} ps 1.2 title {}",
                                series_style(k + 1), gnuplot_string(m_series[k])));
  if (with_front && m_on_front > 0)
    parts.push_back(
        "NaN with points pt 6 ps 2.5 lw 2 lc rgb '#000000' title 'Pareto front "
        "(time, error; per model)'");
  if (m_missed > 0)
    parts.push_back(
        "NaN with points pt 3 ps 1.8 lw 1.5 lc rgb '#ff7f0e' title 'target "
        "missed (model kept)'");
  if (m_failed > 0)
    parts.push_back(
        fmt::format("NaN with points pt 2 ps 2 lc rgb '#d62728' title {}",
                    gnuplot_string(fmt::format("FAILED ({} run{}): crosses at the top, no error",
                                               m_failed, m_failed == 1 ? "" : "s"))));
  parts.push_back("NaN with lines dt 2 lw 1 lc rgb '#555555' title 'tolerance ladder'");
  return "unset label\nunset title\nunset border\nunset tics\nunset xlabel\nunset ylabel\n"
         "unset grid\nset key center center horizontal maxrows 3 noenhanced\nset xrange [0:1]\n"
         "set yrange [0:1]\n"
         "unset logscale\n" +
         plot_of(parts);
}

// Small multiples: one panel per model on shared axes, up to three per row, and below them one
// key for all panels, laid out by hand (a layout grid would give the key a whole row).
std::string BenchCharts::chart(const std::string& title, const std::string& axes,
                               const std::string& x, const FailedX& failed_x,
                               bool with_front) const {
  const std::size_t columns = std::min<std::size_t>(m_models.size(), 3);
  const std::size_t rows_of_panels = (m_models.size() + columns - 1) / columns;
  const int height = chart_height(rows_of_panels);
  const double key_fraction = 150.0 / height;  // the key's strip at the bottom
  const double title_fraction = 30.0 / height;
  const double panel_h =
      (1.0 - key_fraction - title_fraction) / static_cast<double>(rows_of_panels);
  const double panel_w = 1.0 / static_cast<double>(columns);
  const double y_low = m_bottom > 0.0 ? m_bottom / 3.0 : 1e-16;
  const double y_high =
      3.0 * failed_y(m_most_failed_in_a_panel > 0 ? m_most_failed_in_a_panel - 1 : 0);
  std::string body = fmt::format("set multiplot title {} noenhanced\n", gnuplot_string(title));
  for (std::size_t m = 0; m < m_models.size(); ++m) {
    const std::size_t row = m / columns, column = m % columns;
    body += fmt::format(
        "set origin {},{}\nset size {},{}\n"
        "set logscale y\nset grid\nset border\nset tics\nunset key\nset format y '%g'\n"
        "set yrange [{}:{}]\nset ylabel 'verified band error'\n",
        gp_number(panel_w * static_cast<double>(column)),
        gp_number(key_fraction + panel_h * static_cast<double>(rows_of_panels - 1 - row)),
        gp_number(panel_w), gp_number(panel_h), gp_number(y_low), gp_number(y_high));
    body += axes + panel_plot(m_models[m], x, failed_x, with_front);
  }
  body += fmt::format("set origin 0,0\nset size 1,{}\n", gp_number(key_fraction)) +
          key_panel(with_front) + "unset multiplot\n";
  return body;
}

std::vector<PlotScript> BenchCharts::scripts() const {
  const std::size_t columns = std::min<std::size_t>(m_models.size(), 3);
  const int width = 1200;
  const int height = chart_height((m_models.size() + columns - 1) / columns);
  const double x_low = m_fail_x / 1.5;
  const double x_high = std::max(m_max_seconds, m_fail_x) * 1.5;
  const FailedX seconds_or_fail_x = [this](std::size_t i) {
    return m_rows[i].seconds > 0.0 ? m_rows[i].seconds : m_fail_x;
  };
  std::vector<PlotScript> scripts;
  scripts.push_back(
      {"bench_time_error",
       chart("ecmor bench: run time vs achieved band error, one panel per model (circled: "
             "Pareto front)",
             fmt::format("set logscale x\nset format x '%g'\nset xrange [{}:{}]\n"
                         "set xlabel 'total run time [s]'\n",
                         gp_number(x_low), gp_number(x_high)),
             "$11", seconds_or_fail_x, true),
       width, height});
  scripts.push_back(
      {"bench_order_error",
       chart(
           "ecmor bench: reduced order vs achieved band error, one panel per model",
           fmt::format("unset logscale x\nset format x '%g'\nset xrange [0:{}]\n"
                       "set xlabel 'reduced order'\n",
                       std::max<Index>(1, m_max_order + m_max_order / 10 + 1)),
           "$9", [this](std::size_t i) { return static_cast<double>(m_rows[i].order); }, false),
       width, height});
  return scripts;
}

}  // namespace

std::string bench_markdown(const std::vector<BenchRow>& rows) {
  std::string out =
      "| model | N | reducer | strategy | tolerance | result | order | verified error | "
      "H∞ error (abs.) | total s | reducer s | full response s | reference model s | "
      "sparse s (all threads) | sparse share of reducer | factorisations (reducer) |\n"
      "|---|---:|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const BenchRow& r : rows) {
    const std::string result = r.met ? std::string("met") : r.termination;
    // "(band)": the sampled band supremum, not the norm over all frequencies.
    const std::string hinf =
        r.order > 0 ? fmt::format("{:.2e}{}", r.hinf_error, r.hinf_scope == "band" ? " (band)" : "")
                    : std::string("-");
    out += fmt::format(
        "| {} | {} | {} | {} | {:g} | {} | {} | {:.2e} | {} | {:.2f} | {:.3f} | "
        "{:.2f} | {:.2f} | {:.2f} | {:.0f}% | {} ({}) |\n",
        r.model, r.n_full, r.reducer, r.strategy, r.tolerance, result,
        r.order > 0 ? std::to_string(r.order) : std::string("-"), r.verified_error, hinf, r.seconds,
        r.reducer_seconds, r.full_response_seconds, r.reference_seconds, r.sparse_seconds,
        100.0 * r.reducer_sparse_share, r.factorizations, r.reducer_factorizations);
  }
  return out;
}

void BenchReport::write(const std::vector<BenchRow>& rows) {
  write_text_atomically(m_out / "bench.csv", to_csv(rows));
  nlohmann::json j = nlohmann::json::array();
  for (const BenchRow& r : rows) j.push_back(to_json(r));
  write_text_atomically(m_out / "bench.json", j.dump(2) + "\n");
  write_text_atomically(m_out / "bench.md", bench_markdown(rows));
  write_charts(rows);
}

void BenchReport::write_charts(const std::vector<BenchRow>& rows) {
  const BenchCharts charts(rows);
  write_text_atomically(m_out / "bench_chart.csv", charts.csv());
  try {
    render_plots(m_out, charts.scripts(), PlotFormat::Both);
  } catch (const GnuplotNotFound& e) {
    if (!m_noted && !m_quiet) fmt::print("note: {}\n", e.what());
    m_noted = true;
  } catch (const Error& e) {
    if (!m_noted) fmt::print(stderr, "ecmor: warning: bench charts not rendered: {}\n", e.what());
    m_noted = true;
  }
}

}  // namespace ecmor::app
