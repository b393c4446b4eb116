#pragma once
/// \file plot.hpp
/// The plots of a finished run and of `ecmor simulate`: what each one shows. Their data files come
/// from plot_data.hpp, the rendering from gnuplot.hpp (scripts and data are written first, so
/// without gnuplot they are still there).

#include <filesystem>
#include <string>
#include <vector>

#include "ecmor/base/types.hpp"
#include "gnuplot.hpp"

namespace ecmor::app {

/// Plots of a finished run in `run_dir` (written there by `ecmor reduce`):
///  * sigma.{png,svg}: sigma_max(H(i 2 pi f)) of the full model (band_error.csv's
///    reference_spectral) and of the reduced model (evaluated here from the reduced model files)
///    over the re-check grid, log-log; the columns written to sigma.csv
///    (f_hz,full_sigma_max,reduced_sigma_max,error_sigma_max).
///  * error.{png,svg}: eps_2(f) and eps_F(f) (band_error.csv) with the tolerance line.
///  * convergence.{png,svg}: band error vs iteration and vs order (history.csv, re-written as
///    convergence.csv: iteration,order,band_error,meets_tolerance,phase), with the tolerance line.
/// Returns the image files written.
/// \throws InputError naming summary.json, band_error.csv or history.csv when one is missing or
///         malformed (with the line and the rule broken, for the CSV files), or the reduced model
///         files; GnuplotNotFound (the data files and scripts are written
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
