#pragma once
/// \file h2_norm.hpp
/// H2 norms of stable models and of the error between two models (seed Eqs. 16 and 18):
///     ||G||_H2^2 = (1/2pi) integral_{-inf}^{inf} ||G(i omega)||_F^2 d omega
///                = (1/pi) integral_0^inf ||G(i omega)||_F^2 d omega  (real models)
///                = trace(C P C'),  A P E' + E P A' + B B' = 0.
///  * Dense models (reduced models, or small full models through densify()): h2_norm and
///    h2_error_norm, by Gramians (lyapunov.hpp), O(n^3).
///  * Large full models (no dense N x N matrix): h2_error_quadrature, adaptive Gauss-Kronrod
///    quadrature of the integral with the full model's sparse frequency response.
/// The H2 norm exists for asymptotically stable, strictly proper models only: unstable models and
/// descriptor models with singular E (DAEs) are refused with an InputError.

#include <optional>
#include <string>
#include <vector>

#include "ecmor/export.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/measures/band_error.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

/// ||G||_H2 = sqrt(trace(C P C')) with the controllability Gramian of the model's first-order
/// realisation (first_order_realization in lyapunov.hpp).
/// \throws InputError for an unstable model (naming the poles with Re >= 0) or a singular E (M).
ECMOR_API double h2_norm(const ReducedModel& model);

/// ||Ga - Gb||_H2 of two dense models of either kind with the same inputs and outputs:
///     ||Ga - Gb||^2 = trace(Ca Pa Ca') + trace(Cb Pb Cb') - 2 trace(Ca X Cb'),
///     A_a X E_b' + E_a X A_b' + Ba Bb' = 0  (the off-diagonal block of the Gramian of the
/// block-diagonal error system). The subtraction loses about log10(||G|| / ||Ga - Gb||)^2 digits:
/// a relative error of 1e-4 is still obtained to about 1e-8 relative. For a small full model use
/// h2_error_norm(densify(full), reduced).
/// \throws InputError when the models' inputs or outputs differ, or as h2_norm for either model.
ECMOR_API double h2_error_norm(const ReducedModel& a, const ReducedModel& b);

/// Both norms and the error norm of two dense models from one Schur form per model.
struct H2Comparison {
  double norm_a = 0.0;  ///< ||Ga||_H2
  double norm_b = 0.0;  ///< ||Gb||_H2
  double error = 0.0;   ///< ||Ga - Gb||_H2 (as h2_error_norm); error / norm_a is the relative error
};
/// ||Ga||, ||Gb|| and ||Ga - Gb|| at the cost of one h2_error_norm (half that of three calls).
/// \throws as h2_error_norm.
ECMOR_API H2Comparison h2_compare(const ReducedModel& a, const ReducedModel& b);

/// <Ga, Gb>_H2 = (1/2pi) integral trace(Ga(i w)^H Gb(i w)) dw = trace(Ca X Cb') (X as above), the
/// H2 inner product of two stable dense models. h2_inner_product(a, a) = h2_norm(a)^2.
ECMOR_API double h2_inner_product(const ReducedModel& a, const ReducedModel& b);

/// Options of h2_error_quadrature. The adaptive quadrature's fields (relative_tolerance,
/// absolute_tolerance, max_evaluations, initial_intervals) obey AdaptiveQuadratureOptions::specs().
struct ECMOR_API H2QuadratureOptions {
  /// Of the estimated error of the integral ||G - Gr||^2 relative to its value (1e-10: about
  /// 5e-11 relative on the norm).
  double relative_tolerance = 1e-10;
  /// Floor of the estimated error of the integral (in ||G||^2 units), for errors that may be zero.
  double absolute_tolerance = 0.0;
  /// Full-model frequency responses (sparse factorisations) at most.
  Index max_evaluations = 4000;
  /// Threads of the full model's response (<= 0: OpenMP's default).
  int threads = 0;
  /// The scale w0 [rad/s] of the map omega = w0 tan(theta); 0: automatic (the geometric mean of the
  /// reduced model's |poles|, else of the full model's row-norm ratios ||A_i|| / ||E_i|| or
  /// sqrt(||K_i|| / ||M_i||)). Must be >= 0 and finite.
  double scale_rad_s = 0.0;
  /// Initial equal subintervals of theta in [0, pi/2] before the breakpoints are added.
  Index initial_intervals = 8;
  /// Extra breakpoints in omega [rad/s] (e.g. known resonances of the full model), each > 0.
  std::vector<double> breakpoints_rad_s;
  /// When set, the band (frequency-limited) H2 norm: the integral below over omega in
  /// [2 pi f_min, 2 pi f_max] only (and its mirror image), i.e.
  ///     ||G - Gr||_{H2,band}^2 = (1/pi) integral_{w1}^{w2} ||G(i w) - Gr(i w)||_F^2 dw.
  /// Gawronski and Juang (1990); Petersson (2013). The band must satisfy Band::validate().
  std::optional<Band> band;
  /// \throws ConfigError naming the field, the value and the rule.
  void validate() const;
};

/// Result of h2_error_quadrature. Not reaching the tolerance is a result (converged = false), not
/// an exception.
struct ECMOR_API H2Result {
  double value = 0.0;           ///< ||G - Gr||_H2 (or ||G||_H2)
  double error_estimate = 0.0;  ///< estimated absolute error of value (integral_error / (2 value))
  double integral = 0.0;        ///< value^2
  double integral_error = 0.0;  ///< sum of the intervals' error estimates (see h2_error_quadrature)
  Index evaluations = 0;        ///< full-model frequency responses computed
  Index intervals = 0;          ///< subintervals of theta at the end
  double scale_rad_s = 0.0;     ///< w0 used
  bool converged = false;       ///< integral_error <= max(relative_tolerance |integral|, absolute)
  std::string method;           ///< e.g. "Gauss-Kronrod 7/15 on omega = w0 tan(theta), ..."
};

/// ||G - Gr||_H2 of a large full model G and a reduced model Gr (reduced == nullptr: ||G||_H2)
/// without dense N x N matrices, from
///     ||G - Gr||^2 = (1/pi) integral_0^inf ||G(i w) - Gr(i w)||_F^2 dw
/// mapped to theta in [0, pi/2) by w = w0 tan(theta) (the integrand stays bounded at pi/2 for
/// strictly proper models) and integrated by globally adaptive Gauss-Kronrod 7/15: the
/// intervals with the largest error estimates are bisected until their sum is within tolerance
/// or the budget is spent. An interval's estimate is QUADPACK's (qk15): |K15 - G7| scaled by
/// min(1, (200 |K15 - G7| / resasc)^1.5), resasc the integral of |f - mean f| over it; it is
/// a heuristic, not a bound (measured: the true error was below the estimate on every shared
/// model tested). Breakpoints: the images of |Im lambda| of the reduced
/// model's poles (where the error peaks) and options.breakpoints_rad_s. Every round's new nodes
/// are evaluated in one parallel call of ecmor::frequency_response; Gr through ReducedResponse.
/// The full model must be asymptotically stable and strictly proper (not checked: an unstable
/// G has no H2 norm, and the integral then measures the L2 norm of its frequency response).
/// Accuracy measured against the dense Gramian formula (tests/core/test_h2_norm.cpp): see
/// docs/error-measures.md, "H2 norms".
/// \throws InputError when Gr's inputs/outputs differ from G's or Gr is unstable; ConfigError for
///         invalid options; NumericalError when a node hits a pole.
ECMOR_API H2Result h2_error_quadrature(const Model& full, ShiftedSolver& solver,
                                       const ReducedModel* reduced,
                                       const H2QuadratureOptions& options = {});

}  // namespace ecmor
