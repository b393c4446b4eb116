#pragma once
// wall_timer.hpp: adds the wall time of a scope to a running total. Private to core (the band
// error's accounting of where a run's time goes: band_error.cpp, band_error_estimate.cpp).
#include <chrono>

namespace ecmor::detail {

/// Adds the seconds from construction to destruction to `total`, however the scope is left (an
/// exception included). Nested timers on the same total count the time once: only the outermost
/// adds, tracked by `depth`.
class WallTimer {
 public:
  WallTimer(double& total, int& depth)
      : m_total(total), m_depth(depth), m_start(std::chrono::steady_clock::now()) {
    ++m_depth;
  }
  ~WallTimer() {
    if (--m_depth == 0)
      m_total += std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
  }
  WallTimer(const WallTimer&) = delete;
  WallTimer& operator=(const WallTimer&) = delete;

 private:
  double& m_total;
  int& m_depth;
  std::chrono::steady_clock::time_point m_start;
};

}  // namespace ecmor::detail
