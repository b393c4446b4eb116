#pragma once
/// \file pareto.hpp
/// The Pareto front of benchmark runs in the (cost, error) plane, both to be minimised. Pure
/// functions, no I/O: the bench charts mark the front, the tests check it without gnuplot.

#include <cmath>
#include <cstddef>
#include <vector>

namespace ecmor::app {

/// One run as a point of the trade-off. A failed run (no model, no finite error) is not valid and
/// is never on the front, whatever its numbers.
struct TradeoffPoint {
  double cost = 0.0;   ///< e.g. run time in seconds; smaller is better
  double error = 0.0;  ///< achieved (verified) band error; smaller is better
  bool valid = true;   ///< false for a failed run
};

/// True when `q` dominates `p`: no worse in both coordinates and strictly better in one.
inline bool dominates(const TradeoffPoint& q, const TradeoffPoint& p) {
  return q.cost <= p.cost && q.error <= p.error && (q.cost < p.cost || q.error < p.error);
}

/// front[i] is true when points[i] is valid, has finite cost and error, and no other such point
/// dominates it. Equal points do not dominate each other, so ties are all on the front. O(n^2),
/// for the few hundred runs of a benchmark.
inline std::vector<bool> pareto_front(const std::vector<TradeoffPoint>& points) {
  auto usable = [](const TradeoffPoint& p) {
    return p.valid && std::isfinite(p.cost) && std::isfinite(p.error);
  };
  std::vector<bool> front(points.size(), false);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!usable(points[i])) continue;
    bool dominated = false;
    for (std::size_t j = 0; j < points.size() && !dominated; ++j) {
      dominated = j != i && usable(points[j]) && dominates(points[j], points[i]);
    }
    front[i] = !dominated;
  }
  return front;
}

}  // namespace ecmor::app
