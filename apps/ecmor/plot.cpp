// The plots of a run and of a simulation: which curves each picture shows, from which data file.
// The data files are written first (plot_data.hpp), so every curve can be checked against a file.
#include "plot.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>

#include "ecmor/base/error.hpp"
#include "plot_data.hpp"

namespace fs = std::filesystem;

namespace ecmor::app {
namespace {

// "model: reducer / strategy", the head of every run plot's title.
std::string who(const RunFacts& run) {
  return fmt::format("{}: {} / {}", run.model_name, run.reducer, run.strategy);
}

PlotScript sigma_script(const RunFacts& run) {
  return {
      "sigma",
      fmt::format("set logscale xy\n"
                  "set grid\n"
                  "set key bottom left\n"
                  "set format x '%g'\n"
                  "set xrange [{}:{}]\n"
                  "set xlabel 'f [Hz]'\n"
                  "set ylabel 'sigma_max(H(i 2 pi f))'\n"
                  "set title {}\n"
                  "plot 'sigma.csv' skip 1 using 1:2 with lines lw 3 lc rgb '#1f77b4' title "
                  "'full model', \\\n"
                  "     '' skip 1 using 1:3 with lines lw 1.5 dt 2 lc rgb '#d62728' title {}, "
                  "\\\n"
                  "     '' skip 1 using 1:4 with lines lw 1 lc rgb '#7f7f7f' title "
                  "'error sigma_max(H - Hr)'\n",
                  run.f_min_hz, run.f_max_hz,
                  gnuplot_string(fmt::format("{}: largest singular value over the band", who(run))),
                  gnuplot_string(fmt::format("reduced model (order {})", run.order)))};
}

PlotScript error_script(const RunFacts& run) {
  // Two title lines: one would be clipped at the image width.
  const std::string title =
      gnuplot_string(fmt::format("{}, order {}: verified sup eps = {:.3e}", who(run), run.order,
                                 run.verified_band_error)) +
      ".\"\\n\"." +
      gnuplot_string(fmt::format("{} norm, tolerance {:g} ({}), band [{:g}, {:g}] Hz", run.norm,
                                 run.tolerance, run.termination, run.f_min_hz, run.f_max_hz));
  return {
      "error",
      fmt::format("set logscale xy\n"
                  "set grid\n"
                  "set key bottom right\n"
                  "set format x '%g'\n"
                  "set format y '%g'\n"
                  "set xrange [{}:{}]\n"
                  "set xlabel 'f [Hz]'\n"
                  "set ylabel 'relative error'\n"
                  "set title {}\n"
                  "plot 'band_error.csv' skip 1 using 1:2 with lines lw 2 lc rgb '#1f77b4' title "
                  "'eps_2(f)', \\\n"
                  "     '' skip 1 using 1:3 with lines dt 2 lc rgb '#2ca02c' title 'eps_F(f)', \\\n"
                  "     {} with lines lw 1.5 lc rgb '#d62728' title {}\n",
                  run.f_min_hz, run.f_max_hz, title, run.tolerance,
                  gnuplot_string(fmt::format("tolerance {:g}", run.tolerance)))};
}

PlotScript convergence_script(const RunFacts& run) {
  const double verified = run.verified_band_error;
  return {
      "convergence",
      fmt::format("set multiplot layout 1,2 title {0}\n"
                  "set logscale y\n"
                  "set grid\n"
                  "set key top right\n"
                  "set format y '%g'\n"
                  "set offsets 0.5, 0.5, 0, 0\n"
                  "set ylabel 'band error (sup over the sampled band)'\n"
                  "set xlabel 'iteration'\n"
                  "plot 'convergence.csv' skip 1 using 1:3 with linespoints pt 7 lc rgb "
                  "'#1f77b4' title 'band error', \\\n"
                  "     {1} with lines lc rgb '#d62728' title {2}\n"
                  "set xlabel 'reduced order'\n"
                  "plot 'convergence.csv' skip 1 using 2:3 with points pt 7 lc rgb '#1f77b4' "
                  "title 'band error', \\\n"
                  "     {1} with lines lc rgb '#d62728' title {2}, \\\n"
                  "     '+' using ({3}):({4}) every ::0::0 with points pt 6 ps 2.5 lw 2 lc "
                  "rgb '#000000' title 'reported model (verified)'\n"
                  "unset multiplot\n",
                  gnuplot_string(fmt::format("{}: convergence ({})", who(run), run.termination)),
                  run.tolerance, gnuplot_string(fmt::format("tolerance {:g}", run.tolerance)),
                  run.order, std::isfinite(verified) ? fmt::format("{}", verified) : "NaN"),
      1200, 550};
}

}  // namespace

std::vector<fs::path> plot_run(const fs::path& run_dir, PlotFormat format) {
  // The required files are checked before anything is written.
  const fs::path summary_path = run_dir / "summary.json";
  for (const fs::path& p : {summary_path, run_dir / "band_error.csv", run_dir / "history.csv"}) {
    if (!fs::is_regular_file(p)) {
      throw InputError(fmt::format(
          "{}: not found (not a finished ecmor run directory, or a run without a model)",
          p.string()));
    }
  }
  const RunFacts run = read_run_facts(summary_path);
  write_sigma_csv(run_dir);
  write_convergence_csv(run_dir);
  return render_plots(run_dir, {sigma_script(run), error_script(run), convergence_script(run)},
                      format);
}

std::vector<std::filesystem::path> plot_time_response(const std::filesystem::path& run_dir,
                                                      Index outputs, const std::string& title,
                                                      bool log_time, PlotFormat format,
                                                      Index max_outputs) {
  const Index shown = std::min(outputs, max_outputs);
  const char* colours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd"};
  // The reduced output dashed in a darker shade of its full output's colour.
  const char* dark[] = {"#0b3c61", "#7a1414", "#165016", "#4b3366"};
  std::string top, bottom;
  // On a log axis the row at t = 0 is left out (every ::1: from the second data row on).
  const char* rows = log_time ? "every ::1 " : "";
  for (Index i = 0; i < shown; ++i) {
    const Index y = 2 + i, yr = 2 + outputs + i;  // gnuplot columns (1-based; column 1 is t)
    const char* c = colours[i % 4];
    top += fmt::format(
        "{}'time_response.csv' skip 1 {}using 1:{} with lines lw 2 lc rgb '{}' title "
        "'y{} full', \\\n     '' skip 1 {}using 1:{} with lines dt 2 lw 2 lc rgb "
        "'{}' title 'y{} reduced'",
        i == 0 ? "plot " : ", \\\n     ", rows, y, c, i + 1, rows, yr, dark[i % 4], i + 1);
    bottom += fmt::format(
        "{}'time_response.csv' skip 1 {}using 1:(column({}) - column({})) with "
        "lines lc rgb '{}' title 'y{} - yr{}'",
        i == 0 ? "plot " : ", \\\n     ", rows, y, yr, c, i + 1, i + 1);
  }
  const std::string more =
      shown < outputs ? fmt::format(" (first {} of {} outputs)", shown, outputs) : std::string();
  PlotScript script{"time_response",
                    fmt::format("set datafile separator ','\n"
                                "set multiplot layout 2,1 title {}\n"
                                "set grid\nset key outside right\nset format y '%g'\n{}"
                                "set ylabel 'output y(t)'\n{}\n"
                                "set xlabel 't [s]'\nset ylabel 'error y(t) - yr(t) (Eq. 11)'\n{}\n"
                                "unset multiplot\n",
                                gnuplot_string(title + more),
                                log_time ? "set logscale x\nset format x '%g'\n" : "", top, bottom),
                    1100, 800};
  return render_plots(run_dir, {script}, format);
}

}  // namespace ecmor::app
