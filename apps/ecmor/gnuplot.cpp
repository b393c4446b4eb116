// gnuplot as an external program: the script around a plot's body, the search on PATH, the run
// (no shell) and its error report.
#include "gnuplot.hpp"

#include <fmt/core.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>

#include "ecmor/base/atomic_file.hpp"
#include "ecmor/interop/subprocess.hpp"

namespace fs = std::filesystem;

namespace ecmor::app {
namespace {

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

}  // namespace ecmor::app
