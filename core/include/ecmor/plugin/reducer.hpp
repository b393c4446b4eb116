#pragma once
/// \file reducer.hpp
/// The reducer plugin interface. A reducer turns a full model into a projection basis (V, W) and a
/// reduced model of a requested order. The driver (a strategy) calls reduce() repeatedly with
/// growing (or shrinking) orders and possibly moved expansion points; a reducer should reuse
/// whatever it can between calls (factorisations, computed vectors), i.e. grow incrementally.
///
/// Lifecycle:  factory.create(params)  ->  setup(context)  ->  reduce(request) ... reduce(request)
/// Reducers never print; they throw ecmor::Error subclasses for bad input or numerical breakdown.

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "ecmor/base/parameters.hpp"
#include "ecmor/export.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/band.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

/// An expansion (interpolation) point s0 and the number of moments matched there. Points inside
/// a band are s0 = i 2 pi f (use point_at_hz); real points s0 >= 0 are allowed too. A complex point
/// also interpolates at its conjugate, since projection bases are real.
struct ExpansionPoint {
  Complex s{0.0, 0.0};
  Index moments = 1;
  friend bool operator==(const ExpansionPoint&, const ExpansionPoint&) = default;
};

/// The point s0 = i 2 pi f_hz with `moments` moments.
inline ExpansionPoint point_at_hz(double f_hz, Index moments = 1) {
  return ExpansionPoint{Complex(0.0, kTwoPi * f_hz), moments};
}

/// What the driver hands a reducer once, before the first reduce().
struct ReductionContext {
  const Model* model = nullptr;     ///< the full model (outlives the reducer's use of it)
  ShiftedSolver* solver = nullptr;  ///< shared factorisations and counters
  Band band;                        ///< the frequency band of interest (Hz)
};

/// One request for a reduced model.
///  * points empty: order is the requested number of columns of V; the reducer chooses how (modal:
///    modes selected for the band; Krylov: more moments at its configured points).
///  * points given (reducers with ReducerInfo::uses_expansion_points): the reducer builds the
///    subspace of exactly these points and moments; order > 0 then caps the number of columns
///    (keeping the first ones built), order = 0 means "all that the points imply". Reducers that
///    do not use points throw ConfigError when given some.
///  * modes > 0 (only with points, and only for reducers with ReducerInfo::modal_block): a mixed
///    basis. Its first columns are the reducer's modal block, the model it returns for
///    ReductionRequest{modes, {}} (the `modes` modes it ranks first for the band, with its static
///    correction when configured); the points' columns follow. order > 0 caps the whole basis as
///    above. The driver's guard refuses modes > 0 for other reducers and without points.
struct ReductionRequest {
  Index order = 1;
  std::vector<ExpansionPoint> points;
  Index modes = 0;
};

/// The diagnostic key under which a reducer reports the number of reduced poles with Re >= 0
/// (NaN: not computed); strategies use it, when present, instead of computing the poles again.
inline constexpr const char* kUnstablePolesDiagnostic = "unstable_poles";

/// What a reducer returns for a request.
struct ReducerResult {
  ReducedModel model;                  ///< the reduced model (usually project(full, V, W))
  Matrix V;                            ///< N x n right basis
  Matrix W;                            ///< N x n left basis (W = V for one-sided/Galerkin methods)
  std::vector<ExpansionPoint> points;  ///< points actually used (for the history), may be empty
  /// Free-form numeric diagnostics for the history (e.g. "orthogonality_loss", "eigen_residual");
  /// kUnstablePolesDiagnostic is the one the strategies read.
  std::map<std::string, double> diagnostics;
  std::string note;  ///< one line for the history, e.g. "12 modes + 1 static correction"
};

class ECMOR_API Reducer {
 public:
  virtual ~Reducer();
  /// Binds the reducer to a model, solver and band. Called once. May throw InputError when the
  /// model does not suit the method (e.g. "modal: M is not positive definite").
  virtual void setup(const ReductionContext& context) = 0;
  /// Builds the reduced model of order request.order (the reducer may return fewer columns, e.g.
  /// after deflation or when the model is exhausted; never more than request.order + its
  /// documented extra, e.g. static-correction columns).
  virtual ReducerResult reduce(const ReductionRequest& request) = 0;
  /// The largest order this reducer can deliver on the bound model (kUnlimitedOrder if unknown).
  virtual Index max_order() const { return kUnlimitedOrder; }
  /// Smallest meaningful order increment (e.g. 1 mode); strategies grow by multiples of it.
  virtual Index order_step() const { return 1; }
};

/// Static description of a reducer, for `ecmor plugins` and error messages.
struct ReducerInfo {
  std::string name;         ///< YAML name, snake_case, unique across loaded plugins
  std::string description;  ///< one line
  std::string version;      ///< the plugin's own version
  std::vector<ParameterDoc> parameters;
  bool second_order = true;  ///< accepts second-order models
  bool descriptor = false;   ///< accepts descriptor models
  bool uses_expansion_points = false;
  /// Accepts ReductionRequest::modes: a modal block in front of the points' columns (modal).
  bool modal_block = false;
};

/// A named constructor of reducers. create() reads (and so marks as known) its parameters and
/// throws ConfigError on invalid values; the caller checks for unknown keys afterwards.
struct ReducerFactory {
  ReducerInfo info;
  std::function<std::unique_ptr<Reducer>(const ParameterMap&)> create;
};

/// The rules every ReducerResult obeys at the plugin boundary (the registry checks each result of
/// every reducer it created; the conformance suite relies on them):
///  * V is N x n, or 2N x n for a second-order model reduced through its first-order realisation
///    x = [q; q'] (then the reduced model is a descriptor model); W has V's shape; n >= 1;
///  * the reduced model has n states and the full model's inputs and outputs;
///  * V, W and the reduced matrices are finite.
/// \throws PluginError naming `reducer`, the request and the rule broken (shapes), NumericalError
///         for a NaN or Inf.
ECMOR_API void check_reducer_result(const Model& full, const ReductionRequest& request,
                                    const ReducerResult& result, const std::string& reducer);

}  // namespace ecmor
