#pragma once
/// \file band.hpp
/// The frequency band of a reduction: what the tolerance is measured over, and what every reducer
/// is told (ReductionContext::band). Its own header so that the plugin interface (reducer.hpp)
/// does not pull in the error engine (band_error.hpp).

#include "ecmor/export.hpp"

namespace ecmor {

template <class O>
class OptionSpecs;

/// A frequency band in Hz.
struct ECMOR_API Band {
  double f_min_hz = 0.0;
  double f_max_hz = 0.0;
  /// The keys of the YAML section `band`, their rules and documentation (options.hpp).
  static const OptionSpecs<Band>& specs();
  /// \throws ConfigError "band.<key> = <value>: <rule>" for the first rule of specs() broken.
  void validate() const;
};

}  // namespace ecmor
