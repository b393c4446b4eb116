#pragma once
/// \file gnuplot.hpp
/// gnuplot run as an external program: finding it, writing a script per plot and rendering it.
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

}  // namespace ecmor::app
