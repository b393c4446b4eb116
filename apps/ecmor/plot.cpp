// Plots through gnuplot as an external program. Numbers are computed here (the reduced model's
// sigma_max) or copied from the run's files into small CSV files next to the plots, so that every
// curve on a picture can be checked against a file.
#include "plot.hpp"

#include <fmt/core.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>

#include "ecmor/base/atomic_file.hpp"
#include "ecmor/measures/band_error.hpp"
#include "ecmor/model/model_io.hpp"
#include "ecmor/response/reduced_response.hpp"
#include "ecmor/base/subprocess.hpp"
#include "ecmor/base/types.hpp"

namespace fs = std::filesystem;

namespace ecmor::app {
namespace {

// A CSV file as header names and rows of fields; RFC 4180 quoting (history.csv quotes its text
// fields, and the points field contains commas).
struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;

  std::size_t column(const fs::path& path, const std::string& name) const {
    for (std::size_t k = 0; k < header.size(); ++k) {
      if (header[k] == name) return k;
    }
    throw InputError(fmt::format("{}: no column '{}'", path.string(), name));
  }
};

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        fields.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        fields.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.emplace_back();
    } else if (c != '\r') {
      fields.back() += c;
    }
  }
  return fields;
}

Csv read_csv(const fs::path& path) {
  std::ifstream in(path);
  if (!in)
    throw InputError(
        fmt::format("{}: not found (is this a finished ecmor run directory?)", path.string()));
  Csv csv;
  std::string line;
  if (!std::getline(in, line)) throw InputError(fmt::format("{}: empty file", path.string()));
  csv.header = split_csv_line(line);
  for (std::size_t line_no = 2; std::getline(in, line); ++line_no) {
    if (line.empty()) continue;
    csv.rows.push_back(split_csv_line(line));
    if (csv.rows.back().size() != csv.header.size()) {
      throw InputError(fmt::format("{}:{}: {} fields, the header has {}", path.string(), line_no,
                                   csv.rows.back().size(), csv.header.size()));
    }
  }
  return csv;
}

// strtod reads "inf" and "nan" as written by the run; anything else unparsable is an error.
double to_double(const std::string& s, const fs::path& path) {
  char* end = nullptr;
  const double x = std::strtod(s.c_str(), &end);
  if (s.empty() || *end != '\0') {
    throw InputError(fmt::format("{}: '{}' is not a number", path.string(), s));
  }
  return x;
}

// Shortest text that reads back to the same double; non-finite as "nan" (gnuplot skips the point
// instead of failing on a log axis).
std::string data_number(double x) { return std::isfinite(x) ? fmt::format("{}", x) : "nan"; }

// The script: the plot body once, inside a loop over the formats, so that the PNG and the SVG
// always show the same thing and a user edits one place.
std::string script_text(const PlotScript& p, PlotFormat format) {
  std::string formats;
  for (const std::string& ext : plot_extensions(format)) {
    formats += (formats.empty() ? "" : " ") + ext;
  }
  std::string body;
  // Indent the body for readability inside the loop block.
  std::size_t start = 0;
  while (start < p.body.size()) {
    std::size_t end = p.body.find('\n', start);
    if (end == std::string::npos) end = p.body.size();
    body += "  " + p.body.substr(start, end - start) + "\n";
    start = end + 1;
  }
  return fmt::format(
      "# {0}.gp, written by ecmor. Re-render in this directory with: gnuplot {0}.gp\n"
      "# formats: any of 'png svg'\n"
      "formats = '{1}'\n"
      "do for [fmt in formats] {{\n"
      "  reset\n"
      "  if (fmt eq 'png') {{\n"
      "    set terminal pngcairo size {2},{3} noenhanced font ',10'\n"
      "  }} else {{\n"
      "    set terminal svg size {2},{3} noenhanced font 'sans,10' background '#ffffff'\n"
      "  }}\n"
      "  set output '{0}.'.fmt\n"
      "  set datafile separator ','\n"
      "{4}"
      "  unset output\n"
      "}}\n",
      p.name, formats, p.width, p.height, body);
}

// Runs `gnuplot NAME.gp` in `dir` (run_program: no shell, so the directory name never passes
// through a command line). gnuplot's stderr goes to NAME.gp.log, kept only when gnuplot fails.
void run_gnuplot(const fs::path& gnuplot, const fs::path& dir, const std::string& name) {
  const std::string script = name + ".gp";
  const fs::path log = fs::absolute(dir) / (script + ".log");
  const ProgramExit finished =
      run_program(gnuplot.string(), {script}, dir, log, /*stdout_to_log=*/false);
  if (finished.ok()) {
    std::error_code ignored;
    fs::remove(log, ignored);
    return;
  }
  std::string first_error;
  std::ifstream in(log);
  for (std::string line; std::getline(in, line);) {
    if (line.find_first_not_of(" ^") == std::string::npos) continue;
    first_error = line;
    if (line.find("rror") != std::string::npos) break;
  }
  throw IoError(fmt::format("gnuplot failed on {} ({}); its messages are in {}",
                            (dir / script).string(),
                            first_error.empty() ? finished.describe() : first_error, log.string()));
}

nlohmann::json read_summary(const fs::path& path) {
  std::ifstream in(path);
  if (!in) {
    throw InputError(
        fmt::format("{}: not found (is this a finished ecmor run directory?)", path.string()));
  }
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{}: not valid JSON: {}", path.string(), e.what()));
  }
}

template <class T>
T summary_field(const nlohmann::json& j, const char* key, const fs::path& path) {
  if (!j.contains(key)) throw InputError(fmt::format("{}: no field '{}'", path.string(), key));
  try {
    return j.at(key).get<T>();
  } catch (const nlohmann::json::exception&) {
    throw InputError(fmt::format("{}: field '{}' has the wrong type", path.string(), key));
  }
}

}  // namespace

PlotFormat parse_plot_format(const std::string& name) {
  if (name == "png") return PlotFormat::Png;
  if (name == "svg") return PlotFormat::Svg;
  if (name == "both") return PlotFormat::Both;
  throw ConfigError(fmt::format("plot format '{}': must be png, svg or both", name));
}

std::vector<std::string> plot_extensions(PlotFormat format) {
  switch (format) {
    case PlotFormat::Png:
      return {"png"};
    case PlotFormat::Svg:
      return {"svg"};
    case PlotFormat::Both:
      break;
  }
  return {"png", "svg"};
}

fs::path find_gnuplot() {
  const char* path = std::getenv("PATH");
  if (path == nullptr) return {};
  const std::string dirs = path;
  std::size_t start = 0;
  while (start <= dirs.size()) {
    std::size_t end = dirs.find(':', start);
    if (end == std::string::npos) end = dirs.size();
    // An empty PATH entry means the current directory.
    const fs::path dir = end > start ? fs::path(dirs.substr(start, end - start)) : fs::path(".");
    const fs::path candidate = dir / "gnuplot";
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec) && ::access(candidate.c_str(), X_OK) == 0) {
      return fs::absolute(candidate);
    }
    start = end + 1;
  }
  return {};
}

std::string gnuplot_string(const std::string& text) {
  std::string q = "'";
  for (char c : text) {
    if (c == '\'') q += '\'';
    if (c == '\n') {
      q += ' ';
      continue;
    }
    q += c;
  }
  return q + "'";
}

std::vector<fs::path> render_plots(const fs::path& dir, const std::vector<PlotScript>& scripts,
                                   PlotFormat format) {
  for (const PlotScript& p : scripts) {
    write_text_atomically(dir / (p.name + ".gp"), script_text(p, format));
  }
  const fs::path gnuplot = find_gnuplot();
  if (gnuplot.empty()) {
    std::string names;
    for (const PlotScript& p : scripts) names += (names.empty() ? "" : ", ") + p.name;
    throw GnuplotNotFound(fmt::format(
        "gnuplot not found on PATH: plots {} not rendered (data and gnuplot scripts in {})", names,
        dir.string()));
  }
  std::vector<fs::path> written;
  for (const PlotScript& p : scripts) {
    run_gnuplot(gnuplot, dir, p.name);
    for (const std::string& ext : plot_extensions(format)) {
      written.push_back(dir / (p.name + "." + ext));
    }
  }
  return written;
}

std::vector<fs::path> plot_run(const fs::path& run_dir, PlotFormat format) {
  // Both required files are checked before anything is written.
  const fs::path summary_path = run_dir / "summary.json";
  const fs::path error_path = run_dir / "band_error.csv";
  const fs::path history_path = run_dir / "history.csv";
  for (const fs::path& p : {summary_path, error_path, history_path}) {
    if (!fs::is_regular_file(p)) {
      throw InputError(fmt::format(
          "{}: not found (not a finished ecmor run directory, or a run without a model)",
          p.string()));
    }
  }
  const nlohmann::json summary = read_summary(summary_path);
  const double tolerance = summary_field<double>(summary, "tolerance", summary_path);
  const Index order = summary_field<Index>(summary, "final_order", summary_path);
  const double verified = summary_field<double>(summary, "verified_band_error", summary_path);
  const std::string norm = summary_field<std::string>(summary, "norm", summary_path);
  const std::string reducer = summary_field<std::string>(summary, "reducer", summary_path);
  const std::string strategy = summary_field<std::string>(summary, "strategy", summary_path);
  const std::string termination = summary_field<std::string>(summary, "termination", summary_path);
  const nlohmann::json band = summary_field<nlohmann::json>(summary, "band", summary_path);
  const double f_min = summary_field<double>(band, "f_min_hz", summary_path);
  const double f_max = summary_field<double>(band, "f_max_hz", summary_path);
  std::string model_name = "model";
  for (const char* key : {"dir", "file"}) {
    if (summary.contains("model") && summary["model"].contains(key))
      model_name = fs::path(summary["model"][key].get<std::string>()).filename().string();
  }

  // sigma.csv: the full model's sigma_max as the run computed it (band_error.csv), the reduced
  // model's evaluated here from the written reduced model at the same frequencies.
  const Csv errors = read_csv(error_path);
  const std::size_t c_f = errors.column(error_path, "f_hz");
  const std::size_t c_ref = errors.column(error_path, "reference_spectral");
  const std::size_t c_abs = errors.column(error_path, "absolute_spectral");
  errors.column(error_path, "relative_spectral");
  errors.column(error_path, "relative_frobenius");
  const ReducedModel reduced = read_reduced_model(run_dir);
  const ReducedResponse response(reduced);
  std::string sigma = "f_hz,full_sigma_max,reduced_sigma_max,error_sigma_max\n";
  for (const auto& row : errors.rows) {
    const double f_hz = to_double(row[c_f], error_path);
    double reduced_sigma = std::nan("");
    try {
      reduced_sigma = matrix_norm(response(s_from_hz(f_hz)), ErrorNorm::Spectral);
    } catch (const NumericalError&) {
      // A reduced pole on the grid: no finite value to draw (band_error.csv says inf there).
    }
    sigma += fmt::format("{},{},{},{}\n", data_number(f_hz),
                         data_number(to_double(row[c_ref], error_path)), data_number(reduced_sigma),
                         data_number(to_double(row[c_abs], error_path)));
  }
  write_text_atomically(run_dir / "sigma.csv", sigma);

  // convergence.csv: the numeric columns of history.csv the plot needs, without its quoted text
  // fields (gnuplot does not read RFC 4180 quoting).
  const Csv history = read_csv(history_path);
  const std::size_t h_it = history.column(history_path, "iteration");
  const std::size_t h_order = history.column(history_path, "order");
  const std::size_t h_err = history.column(history_path, "band_error");
  const std::size_t h_met = history.column(history_path, "meets_tolerance");
  const std::size_t h_phase = history.column(history_path, "phase");
  std::string convergence = "iteration,order,band_error,meets_tolerance,phase\n";
  for (const auto& row : history.rows) {
    convergence += fmt::format("{},{},{},{},{}\n", row[h_it], row[h_order],
                               data_number(to_double(row[h_err], history_path)),
                               row[h_met] == "true" ? 1 : 0, row[h_phase]);
  }
  write_text_atomically(run_dir / "convergence.csv", convergence);

  const std::string who = fmt::format("{}: {} / {}", model_name, reducer, strategy);
  std::vector<PlotScript> scripts;
  scripts.push_back(
      {"sigma",
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
                   "     '' skip 1 using 1:3 with lines lw 1.5 dt 2 lc rgb '#d62728' title {}, \\\n"
                   "     '' skip 1 using 1:4 with lines lw 1 lc rgb '#7f7f7f' title "
                   "'error sigma_max(H - Hr)'\n",
                   f_min, f_max,
                   gnuplot_string(fmt::format("{}: largest singular value over the band", who)),
                   gnuplot_string(fmt::format("reduced model (order {})", order)))});
  scripts.push_back(
      {"error",
       fmt::format(
           "set logscale xy\n"
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
           f_min, f_max,
           // Two lines: one would be clipped at the image width.
           gnuplot_string(
               fmt::format("{}, order {}: verified sup eps = {:.3e}", who, order, verified)) +
               ".\"\\n\"." +
               gnuplot_string(fmt::format("{} norm, tolerance {:g} ({}), band [{:g}, {:g}] Hz",
                                          norm, tolerance, termination, f_min, f_max)),
           tolerance, gnuplot_string(fmt::format("tolerance {:g}", tolerance)))});
  scripts.push_back(
      {"convergence",
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
                   "     '+' using ({3}):({4}) every ::0::0 with points pt 6 ps 2.5 lw 2 lc rgb "
                   "'#000000' title 'reported model (verified)'\n"
                   "unset multiplot\n",
                   gnuplot_string(fmt::format("{}: convergence ({})", who, termination)), tolerance,
                   gnuplot_string(fmt::format("tolerance {:g}", tolerance)), order,
                   std::isfinite(verified) ? fmt::format("{}", verified) : "NaN"),
       1200, 550});
  return render_plots(run_dir, scripts, format);
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
