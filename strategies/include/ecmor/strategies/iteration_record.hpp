#pragma once
/// \file iteration_record.hpp
/// One row of the convergence history: what a strategy reports after each iteration. The run layer
/// (ecmor/run/history.hpp) keeps the rows, writes them as history.csv and history.jsonl and hands
/// them to the observer.

#include <map>
#include <string>
#include <vector>

#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/plugin/reducer.hpp"

namespace ecmor {

struct IterationRecord {
  Index iteration = 0;                 ///< 1-based
  std::string phase;                   ///< strategy phase, e.g. "grow", "shrink", "verify"
  Index order = 0;                     ///< reduced order n
  std::vector<ExpansionPoint> points;  ///< expansion points used (may be empty)
  double band_error = 0.0;             ///< sup of the relative band error (target's norm)
  double f_peak_hz = 0.0;              ///< where it peaks
  bool meets_tolerance = false;
  bool stable = true;          ///< all reduced poles in the open left half plane
  double seconds = 0.0;        ///< wall time since the start of the run
  double step_seconds = 0.0;   ///< wall time of this iteration
  SolverCounters counters;     ///< cumulative solver counters at the end of the iteration
  Index full_evaluations = 0;  ///< cumulative full-model frequencies evaluated
  std::string sampling;        ///< how the band was sampled
  std::string note;            ///< reducer's note
  std::map<std::string, double> diagnostics;
};

}  // namespace ecmor
