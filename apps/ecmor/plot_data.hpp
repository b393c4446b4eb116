#pragma once
/// \file plot_data.hpp
/// The numbers behind the plots of a finished run: read from its files (summary.json,
/// band_error.csv, history.csv) or computed from its reduced model, and written as small CSV files
/// next to the plots, so that every curve on a picture can be checked against a file.

#include <filesystem>
#include <string>

#include "ecmor/base/types.hpp"

namespace ecmor::app {

/// What the plots of a run say about it, from its summary.json.
struct RunFacts {
  std::string model_name = "model";  ///< file name of model.dir or model.file
  std::string reducer, strategy;
  std::string norm;         ///< the band error's norm
  std::string termination;  ///< to_string(Termination)
  double tolerance = 0.0;
  Index order = 0;  ///< final_order
  double verified_band_error = 0.0;
  double f_min_hz = 0.0, f_max_hz = 0.0;
};

/// Reads the facts of a run from `summary_path` (its summary.json).
/// \throws InputError naming the file when it is missing or not JSON, and the field when one is
///         missing or has the wrong type.
RunFacts read_run_facts(const std::filesystem::path& summary_path);

/// Writes run_dir/sigma.csv (f_hz,full_sigma_max,reduced_sigma_max,error_sigma_max) at the
/// frequencies of band_error.csv: the full model's sigma_max as the run computed it
/// (reference_spectral), the reduced model's evaluated here from the reduced model files ("nan" at
/// a reduced pole), and the error's (absolute_spectral).
/// \throws InputError naming band_error.csv, its line and column when a column is missing or a
///         field is not a number; or naming the reduced model files.
void write_sigma_csv(const std::filesystem::path& run_dir);

/// Writes run_dir/convergence.csv (iteration,order,band_error,meets_tolerance,phase) from
/// history.csv: the columns the convergence plot reads, meets_tolerance as 1 or 0, without the
/// quoted text fields (gnuplot does not read RFC 4180 quoting).
/// \throws InputError from read_history_csv (file, line and rule).
void write_convergence_csv(const std::filesystem::path& run_dir);

}  // namespace ecmor::app
