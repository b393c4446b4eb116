#pragma once
/// \file conformance.hpp
/// The conformance suite every reducer must pass, bundled or external. It runs a reducer, created
/// by name from a Registry, on small generated models (or models of your own) and checks the
/// contract of reducer.hpp that a strategy relies on:
///
///  * accepts:     setup() succeeds on a model kind the ReducerInfo declares, and refuses an
///                 undeclared kind with a named error (InputError, ConfigError or NumericalError);
///  * dimensions:  at each order of Options::orders the result has 1 <= n <= order + inputs columns
///                 and passes check_reducer_result() (shapes, finite numbers);
///  * projection:  the reduced model is the Petrov-Galerkin projection (W'MV, ...) of the returned
///                 bases: transfer functions agree to Options::tolerance;
///  * full_order:  a basis of full rank reproduces H(s) in and next to the band to
///                 Options::tolerance (skipped, with the reason, when the reducer cannot deliver a
///                 square basis or refuses the full order with a named error);
///  * determinism: two fresh reducers give the same reduced transfer function (to 1e-10);
///  * growth:      growing 2 -> 4 -> 8 and shrinking back to 4 gives the transfer functions of
///  fresh
///                 builds at 8 and 4 (to Options::growth_tolerance);
///  * band:        set up for a band, the reducer needs no larger order to reach
///                 Options::band_tolerance there than when set up for another band;
///  * points:      for reducers with uses_expansion_points, H_r(s0) = H(s0) at a point s0 in the
///                 band; for the others, a request with points is refused with a ConfigError;
///  * bad_input:   an unknown parameter key is a ConfigError naming the key.
///
/// Every comparison of transfer functions is relative to the full model's ||H(s)||_2 at the same
/// frequency; the reference H(s) comes from sparse solves with the full model, never from the
/// reducer. See docs/plugin-guide.md ("Testing with the conformance suite") and `ecmor conform`.

#include <functional>
#include <string>
#include <vector>

#include "ecmor/base/parameters.hpp"
#include "ecmor/export.hpp"
#include "ecmor/measures/band_error.hpp"
#include "ecmor/model/model.hpp"
#include "ecmor/plugin/registry.hpp"

namespace ecmor::conformance {

enum class Status { Passed, Failed, Skipped };
ECMOR_API std::string to_string(Status status);

/// A model to run the suite on, with the band the reducer is set up for and a second band, disjoint
/// from it, for the `band` check.
struct TestModel {
  std::string name;
  Model model;
  Band band;
  Band other_band;
};

/// The generated models of the suite, deterministic and small (N = 30), with separated lightly
/// damped modes in their bands:
///  * "chain_so": a second-order mass-spring-damper chain with Rayleigh damping, 2 inputs, 2
///  outputs;
///  * "stable_descriptor": a first-order model E x' = A x + B u with E diagonal positive definite
///  and
///    A + A' negative definite (so asymptotically stable), 1 input, 2 outputs.
ECMOR_API std::vector<TestModel> builtin_models();

struct ECMOR_API Options {
  /// Models to run on; empty: builtin_models(), each only for the model kinds the reducer declares
  /// (plus the refusal check for the kinds it does not).
  std::vector<TestModel> models;
  /// Orders requested in the dimension, projection and growth checks, ascending, >= 1.
  std::vector<Index> orders{2, 4, 8};
  /// Relative agreement of transfer functions for `projection`, `full_order` and `points`.
  double tolerance = 1e-8;
  /// Relative agreement for `growth` (incremental build against a fresh build).
  double growth_tolerance = 1e-8;
  /// Relative agreement for `determinism`.
  double determinism_tolerance = 1e-10;
  /// `band`: the relative band error to reach on the order ladder 2, 4, ... (up to N, or 2N for
  /// a second-order model).
  double band_tolerance = 1e-2;
  /// Frequencies per band at which transfer functions are compared (log-spaced, plus the band
  /// ends).
  Index frequencies = 40;
  /// Throws ConfigError naming the field, value and rule.
  void validate() const;
};

/// The outcome of one check on one model. `detail` carries the numbers (or the reason for a skip
/// or a failure, with the reducer's own message).
struct CheckResult {
  std::string check;
  std::string model;
  Status status = Status::Passed;
  std::string detail;
  double seconds = 0.0;
};

struct ECMOR_API Report {
  std::string reducer;
  std::vector<CheckResult> checks;
  bool passed() const;  ///< no check failed (skips allowed)
  Index count(Status status) const;
};

/// Runs the suite on reducer `reducer` of `registry` with `parameters` (the YAML reducer mapping
/// minus name; each reducer the suite creates gets a copy). `progress`, if set, is called after
/// each check. Never throws for a misbehaving reducer (that is a failed check).
/// \throws ConfigError for invalid options, an unknown reducer name or invalid parameters.
ECMOR_API Report run(const Registry& registry, const std::string& reducer,
                     const ParameterMap& parameters, const Options& options = {},
                     const std::function<void(const CheckResult&)>& progress = {});

}  // namespace ecmor::conformance
