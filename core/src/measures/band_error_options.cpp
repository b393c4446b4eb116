// band_error_options.cpp: the names of the band error's norms and verification modes (read from
// YAML) and BandErrorOptions::validate (see ecmor/measures/band_error.hpp).
#include <string>

#include "ecmor/base/error.hpp"
#include "ecmor/base/parameters.hpp"
#include "ecmor/measures/band_error.hpp"

namespace ecmor {

std::string to_string(ErrorNorm norm) {
  return norm == ErrorNorm::Spectral ? "spectral" : "frobenius";
}

ErrorNorm parse_error_norm(const std::string& name) {
  if (name == "spectral") return ErrorNorm::Spectral;
  if (name == "frobenius") return ErrorNorm::Frobenius;
  throw ConfigError("unknown error norm '" + name + "'" +
                    suggestion(name, {"spectral", "frobenius"}));
}

std::string to_string(ErrorVerify verify) {
  switch (verify) {
    case ErrorVerify::Dense:
      return "dense";
    case ErrorVerify::Estimate:
      return "estimate";
    case ErrorVerify::Auto:
      break;
  }
  return "auto";
}

ErrorVerify parse_error_verify(const std::string& name) {
  if (name == "dense") return ErrorVerify::Dense;
  if (name == "estimate") return ErrorVerify::Estimate;
  if (name == "auto") return ErrorVerify::Auto;
  throw ConfigError("unknown error.verify '" + name + "'" +
                    suggestion(name, {"dense", "estimate", "auto"}));
}

void BandErrorOptions::validate() const {
  auto bad = [](const std::string& field, const std::string& value, const std::string& rule) {
    throw ConfigError("BandErrorOptions::" + field + " = " + value + ": " + rule);
  };
  if (grid_points < 2) bad("grid_points", std::to_string(grid_points), "must be >= 2");
  if (grid_points > 1000000) bad("grid_points", std::to_string(grid_points), "must be <= 1e6");
  if (max_pole_samples < 0)
    bad("max_pole_samples", std::to_string(max_pole_samples), "must be >= 0");
  if (refine_peaks < 0) bad("refine_peaks", std::to_string(refine_peaks), "must be >= 0");
  if (refine_evaluations < 0 || refine_evaluations > 200) {
    bad("refine_evaluations", std::to_string(refine_evaluations), "must be in [0, 200]");
  }
  if (!(zero_threshold >= 0.0) || !(zero_threshold < 1.0)) {
    bad("zero_threshold", std::to_string(zero_threshold), "must be in [0, 1)");
  }
  if (dense_max_states < 0)
    bad("dense_max_states", std::to_string(dense_max_states), "must be >= 0");
  if (estimate_points < 2 || estimate_points > 1000000)
    bad("estimate_points", std::to_string(estimate_points), "must be in [2, 1e6]");
  if (reference_points < 2 || reference_points > 10000)
    bad("reference_points", std::to_string(reference_points), "must be in [2, 10000]");
  if (check_peaks < 1) bad("check_peaks", std::to_string(check_peaks), "must be >= 1");
  if (random_checks < 0) bad("random_checks", std::to_string(random_checks), "must be >= 0");
  if (check_rounds < 1) bad("check_rounds", std::to_string(check_rounds), "must be >= 1");
  if (probe_solves < 0) bad("probe_solves", std::to_string(probe_solves), "must be >= 0");
}

}  // namespace ecmor
