#pragma once
/// \file strategy.hpp
/// Error-controlled outer loops. A strategy drives one reducer: it asks for reduced models (growing
/// the order or moving expansion points), measures each one's relative band error, and stops with
/// a reason. Missing the tolerance is a result, not an exception.

#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ecmor/base/parameters.hpp"
#include "ecmor/linalg/rigid_body.hpp"
#include "ecmor/measures/band_error.hpp"
#include "ecmor/plugin/reducer.hpp"
#include "ecmor/strategies/iteration_record.hpp"

namespace ecmor {

enum class Termination {
  Converged,         ///< a model meets the tolerance (the smallest found is reported)
  MaxOrderReached,   ///< the order budget ended before the tolerance was met
  IterationLimit,    ///< the iteration budget ended before the tolerance was met
  ReducerExhausted,  ///< the reducer cannot deliver a larger order (e.g. all modes used)
  Stagnated,         ///< the error stopped improving
  Interrupted,       ///< stopped by the observer (user interrupt, time budget)
  Failed,            ///< numerical breakdown; message says where
};
std::string to_string(Termination t);

/// Everything a strategy works with. The pointers outlive the call to run().
struct StrategyContext {
  Reducer* reducer = nullptr;
  /// The reducer's static description (name for messages; uses_expansion_points).
  ReducerInfo reducer_info;
  BandErrorEstimator* estimator = nullptr;
  double tolerance = 1e-3;
  /// The full model's rigid-body modes (rigid_body_modes), against which every reduced model's
  /// stability is judged (reduced_model_stability); nullptr: none (every pole must have Re < 0).
  const RigidBodyModes* full_rigid = nullptr;
  /// A pass is re-checked on a grid this many times denser than the estimator's (independent).
  Index verify_factor = 4;
  /// Called after every iteration with its record; return false to stop (Interrupted).
  std::function<bool(const IterationRecord&)> on_iteration;
  /// Polled between records (e.g. inside an optimiser's objective), so that a stop request (Ctrl-C)
  /// takes effect within one reduction, not at the next history record. May be empty.
  std::function<bool()> stop_requested;
  /// Cumulative counters for the records (solver and full-model evaluations).
  std::function<SolverCounters()> counters;
  std::function<Index()> full_evaluations;
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
};

struct StrategyResult {
  Termination termination = Termination::Failed;
  std::string message;  ///< with numbers: "band error 8.1e-05 <= tolerance 1e-04 at order 24"
  std::optional<ReducerResult> best;  ///< smallest model meeting the target, else the most accurate
  BandError best_error;
  /// best_error is already the independent re-check of `best` (a compressed model's
  /// BandErrorEstimator::verify_near): the acceptance reports it instead of checking again.
  bool best_checked = false;
  std::vector<IterationRecord> history;  ///< always complete, whatever the verbosity
  bool met() const { return termination == Termination::Converged; }
};

class Strategy {
 public:
  virtual ~Strategy();
  virtual StrategyResult run(StrategyContext& context) = 0;
  /// True for strategies that move expansion points: they need a reducer with
  /// ReducerInfo::uses_expansion_points (the driver checks this before any heavy work).
  virtual bool moves_points() const { return false; }
  /// True for strategies that ask for a modal block in front of the points
  /// (ReductionRequest::modes): they need a reducer with ReducerInfo::modal_block.
  virtual bool needs_modal_block() const { return false; }
  /// True for strategies whose order never decreases from one model to the next (grow_order):
  /// a portfolio stops such a member once its order reaches the smallest that met the target.
  virtual bool order_only_grows() const { return false; }
};

/// Creates a strategy by name ("grow_order", ...), reading its parameters.
/// \throws ConfigError for unknown names (listing the valid ones) or invalid/unknown parameters.
std::unique_ptr<Strategy> make_strategy(const std::string& name, const ParameterMap& params);
/// The strategies. A configuration may also name "portfolio", which the run layer runs
/// (ecmor/run/config.hpp, run_strategy_names()).
std::vector<std::string> strategy_names();
/// The documented options of a strategy (key, type, default, meaning with unit and range), from
/// its option specs; what `ecmor plugins` prints. \throws ConfigError for unknown names.
std::vector<ParameterDoc> strategy_parameters(const std::string& name);

}  // namespace ecmor
