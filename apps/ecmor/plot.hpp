#pragma once
/// \file plot.hpp
/// Plots of a finished run and of a benchmark, rendered by gnuplot run as an external program.
///
/// Every plot is a gnuplot script `NAME.gp` plus the data it reads (CSV), both written into the
/// output directory first; gnuplot is then run on the script with the output directory as its
/// working directory, so the scripts name their files without directories (an output path with
/// spaces or quotes never appears in a script or on a command line) and a user can restyle a plot
/// and re-render it with `cd DIR && gnuplot NAME.gp`. Without gnuplot the data and the scripts are
/// still written.

#include <filesystem>
#include <string>
#include <vector>

#include "ecmor/base/error.hpp"
#include "ecmor/base/types.hpp"

namespace ecmor::app {

/// Which image formats a plot is rendered in: PNG (gnuplot's pngcairo terminal), SVG, or both.
enum class PlotFormat { Png, Svg, Both };

/// "png", "svg" or "both". \throws ConfigError naming the value and the valid ones.
PlotFormat parse_plot_format(const std::string& name);

/// The file extensions of a format choice: {"png"}, {"svg"} or {"png", "svg"}.
std::vector<std::string> plot_extensions(PlotFormat format);

/// gnuplot is not on PATH: nothing was rendered; what() names the plots and where their data is.
class GnuplotNotFound : public Error {
 public:
  using Error::Error;
};

/// The full path of the `gnuplot` executable found on $PATH; empty when there is none.
std::filesystem::path find_gnuplot();

/// Quotes `text` as a gnuplot single-quoted string literal ('it''s'), the only escape it has.
std::string gnuplot_string(const std::string& text);

/// A plot to render: `dir/NAME.gp` is written from `body`, which must draw the plot once and may
/// rely on the terminal and the output file being set (per format) by a loop around it, e.g.
///   "set logscale xy\nplot 'sigma.csv' using 1:2 with lines title 'full'\n".
struct PlotScript {
  std::string name;  ///< file stem: NAME.gp, NAME.png, NAME.svg
  std::string body;  ///< gnuplot commands that draw the plot (no terminal/output settings)
  int width = 1000;  ///< image size in pixels (PNG) or SVG user units
  int height = 600;
};

/// Writes `dir/NAME.gp` for every script (each renders all formats of `format` in one gnuplot
/// call), then runs gnuplot on each. Returns the image files written.
/// \throws GnuplotNotFound when gnuplot is not on PATH (after the scripts are written);
///         IoError naming the script and gnuplot's first error line when gnuplot fails, or when a
///         script cannot be written.
std::vector<std::filesystem::path> render_plots(const std::filesystem::path& dir,
                                                const std::vector<PlotScript>& scripts,
                                                PlotFormat format);

/// Plots of a finished run in `run_dir` (written there by `ecmor reduce`):
///  * sigma.{png,svg}: sigma_max(H(i 2 pi f)) of the full model (band_error.csv's
///    reference_spectral) and of the reduced model (evaluated here from the reduced model files)
///    over the re-check grid, log-log; both columns written to sigma.csv
///    (f_hz,full_sigma_max,reduced_sigma_max).
///  * error.{png,svg}: eps_2(f) and eps_F(f) (band_error.csv) with the tolerance line.
///  * convergence.{png,svg}: band error vs iteration and vs order (history.csv, re-written as
///    convergence.csv: iteration,order,band_error,meets_tolerance,phase), with the tolerance line.
/// Returns the image files written.
/// \throws InputError naming summary.json or band_error.csv when one is missing or malformed, or
///         the reduced model files; GnuplotNotFound (the data files and scripts are written
///         first); IoError when gnuplot fails.
std::vector<std::filesystem::path> plot_run(const std::filesystem::path& run_dir,
                                            PlotFormat format = PlotFormat::Both);

/// time_response.{png,svg} of `ecmor simulate` in `run_dir`, from time_response.csv
/// (t,y1..yp,yr1..yrp): the full (solid) and reduced (dashed) outputs over time, at most the first
/// `max_outputs` of them, and below them the output error y_i - yr_i (Eq. 11). `title` heads it.
/// `log_time`: a logarithmic time axis (from the first step; t = 0 is left out).
/// \throws GnuplotNotFound; IoError when gnuplot fails.
std::vector<std::filesystem::path> plot_time_response(const std::filesystem::path& run_dir,
                                                      Index outputs, const std::string& title,
                                                      bool log_time = false,
                                                      PlotFormat format = PlotFormat::Both,
                                                      Index max_outputs = 4);

}  // namespace ecmor::app
