#pragma once
/// \file quadrature.hpp
/// Globally adaptive Gauss-Kronrod 7/15 quadrature of matrix-valued functions, and the band
/// integrals of a model's resolvent that frequency-limited methods need.
///
/// For a band B = [w1, w2] (rad/s) and its mirror image -B, frequency-limited H2 (Petersson
/// 2013; Vuillemin et al. 2013) and frequency-limited Gramians (Gawronski and Juang 1990) use
///     L_B = integral_{B and -B} (i w E - A)^-1 B dw = 2 Re integral_{w1}^{w2} (i w E - A)^-1 B dw
///     L_C = integral_{B and -B} (i w E - A)^-T C' dw (likewise)
/// (a matrix logarithm applied to B, resp. C'); band_resolvent_integrals() computes both by
/// quadrature with one factorisation of P(i w) per node, no 2N matrix (see first_order_view.hpp).

#include <functional>
#include <vector>

#include "ecmor/base/types.hpp"
#include "ecmor/export.hpp"
#include "ecmor/linalg/first_order_view.hpp"
#include "ecmor/model/band.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

template <class O>
class OptionSpecs;

/// Options of integrate_adaptive(). The rules of each field are stated once, in specs().
struct ECMOR_API AdaptiveQuadratureOptions {
  double relative_tolerance = 1e-8;  ///< of the summed error estimate, Frobenius norm
  double absolute_tolerance = 0.0;   ///< floor of the summed error estimate
  Index max_evaluations = 3000;      ///< integrand evaluations
  Index initial_intervals = 8;       ///< equal subintervals to start from

  /// The fields' rules and documentation (options.hpp).
  static const OptionSpecs<AdaptiveQuadratureOptions>& specs();
  /// \throws ConfigError "AdaptiveQuadratureOptions: <field> = <value>: <rule>" (by specs()).
  void validate() const;
};

/// Result of integrate_adaptive(). Not reaching the tolerance is a result, not an exception.
struct ECMOR_API MatrixQuadrature {
  Matrix integral;              ///< the Kronrod sums over all intervals
  double error_estimate = 0.0;  ///< summed interval estimates (Frobenius norm)
  Index evaluations = 0;
  Index intervals = 0;
  bool converged = false;  ///< error_estimate <= max(relative_tolerance ||integral||, absolute)
  /// The final partition's Kronrod nodes and weights (integral ~ sum weights[k] f(nodes[k])),
  /// for integrating other functions resolved by the same partition.
  std::vector<double> nodes, weights;
};

/// A batch integrand: the values at the given points, one matrix per point, all of one size.
using MatrixIntegrand = std::function<std::vector<Matrix>(const std::vector<double>& points)>;

/// integral_a^b f(x) dx by globally adaptive Gauss-Kronrod 7/15: the intervals with the largest
/// error estimates are bisected (up to 16 per round, each round one call of f) until the sum of
/// the estimates is within tolerance or the budget is spent. An interval's estimate is QUADPACK's
/// qk15 heuristic applied to Frobenius norms: ||K15 - G7|| scaled by
/// min(1, (200 ||K15 - G7|| / resasc)^1.5), resasc = integral of ||f - mean f||.
/// \throws ConfigError for invalid options or a <= b not finite; InputError when f returns the
///         wrong number of values, matrices of different sizes, or a non-finite entry (naming
///         the point).
ECMOR_API MatrixQuadrature integrate_adaptive(const MatrixIntegrand& f, double a, double b,
                                              const AdaptiveQuadratureOptions& options = {});

/// The band integrals L_B (state_size() x inputs) and L_C (state_size() x outputs) of the
/// file comment, of the first-order realisation seen through `view`.
struct ECMOR_API BandResolventIntegrals {
  Matrix input;                 ///< L_B
  Matrix output;                ///< L_C
  MatrixQuadrature quadrature;  ///< of [L_B L_C]; integral holds the two side by side
  const char* variable = "";    ///< "log(omega)" or "omega": the integration variable used
  /// A band quadrature rule from the same partition, with the model's response there:
  /// (1/pi) integral_{w1}^{w2} f(w) dw ~ sum weights[k] f(omega[k]), and response[k] = G(i
  /// omega[k]). It gives band H2 norms and errors, e.g. band_h2_squared_error().
  std::vector<double> omega, weights;
  std::vector<ComplexMatrix> response;
};

/// ||G - Gr||^2 over the band, (1/pi) integral_{w1}^{w2} ||G(i w) - Gr(i w)||_F^2 dw, by the rule
/// of `integrals` (an estimate: the partition was refined for the resolvent, whose peaks are G's;
/// reduced == nullptr gives ||G||^2 over the band).
ECMOR_API double band_h2_squared_error(const BandResolventIntegrals& integrals,
                                       const ReducedModel* reduced);

/// L_B and L_C by integrate_adaptive() over t = log(omega) when f_max / f_min > 4 (the wide bands
/// of structural models, where resonances are spread logarithmically), else over omega; one
/// factorisation of the model's P(i omega) per node, through view's solver.
/// \throws ConfigError for an invalid band or options; NumericalError when a node's
///         factorisation fails (a pole on the imaginary axis inside the band), naming the
///         frequency.
ECMOR_API BandResolventIntegrals band_resolvent_integrals(
    FirstOrderView& view, const Band& band, const AdaptiveQuadratureOptions& options = {});

/// The quadrature options of band_resolvent_integrals() for the reducers that need the band
/// integrals of a large model (irka, balanced): a node budget of 20000 rather than
/// integrate_adaptive()'s 3000, since each node is one factorisation and wide bands need many.
ECMOR_API AdaptiveQuadratureOptions band_quadrature_defaults();
/// The keys under which those reducers offer the options, `band_quadrature_tolerance` and
/// `band_quadrature_budget`, with the rules of AdaptiveQuadratureOptions::specs().
ECMOR_API const OptionSpecs<AdaptiveQuadratureOptions>& band_quadrature_specs();

/// beta(s) = integral_{B and -B} dw / (s - i w) = 2 (atan(w2 / s) - atan(w1 / s)) for Re s > 0
/// (complex atan; the path w / s stays off its branch cuts). By the resolvent identity
///     (i w E - A)^-1 B / (s - i w) = (s E - A)^-1 B / (s - i w) + (s E - A)^-1 E (i w E - A)^-1 B,
/// the band integral of the left side is (s E - A)^-1 (B beta(s) + E L_B).
/// \throws InputError when Re s <= 0.
ECMOR_API Complex band_pole_integral(Complex s, const Band& band);

}  // namespace ecmor
