#pragma once
// number_text.hpp: numbers in error messages, written alike across the core (%.6g; complex
// numbers as a+bi). Private to the core's sources.
#include <cstdio>
#include <string>

#include "ecmor/base/types.hpp"

namespace ecmor::detail {

inline std::string number_text(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}

inline std::string number_text(Complex z) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g%+.6gi", z.real(), z.imag());
  return buf;
}

}  // namespace ecmor::detail
