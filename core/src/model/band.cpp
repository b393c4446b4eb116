// band.cpp: see ecmor/model/band.hpp.
#include "ecmor/model/band.hpp"

#include <cmath>
#include <sstream>
#include <string>

#include "ecmor/base/error.hpp"

namespace ecmor {

void Band::validate() const {
  auto fmt = [](double v) {
    std::ostringstream os;
    os << v;
    return os.str();
  };
  if (!std::isfinite(f_min_hz) || !(f_min_hz > 0.0)) {
    throw ConfigError("band.f_min_hz = " + fmt(f_min_hz) +
                      ": must be a finite frequency > 0 Hz (the band is sampled in log scale; use "
                      "e.g. 1e-3 * f_max_hz for a band starting near 0)");
  }
  if (!std::isfinite(f_max_hz) || !(f_max_hz > f_min_hz)) {
    throw ConfigError("band.f_max_hz = " + fmt(f_max_hz) +
                      ": must be finite and > band.f_min_hz = " + fmt(f_min_hz));
  }
}

}  // namespace ecmor
