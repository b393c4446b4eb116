#pragma once
/// \file hinf_norm.hpp
/// H-infinity norms of stable dense models and of the error between two models (seed Eqs. 6-18):
///     ||G||_Hinf = sup_omega sigma_max(G(i omega)),
/// computed by the level-set method of Boyd and Balakrishnan ("A regularity result for the
/// singular values of a transfer matrix and a quadratically convergent algorithm for computing its
/// L-infinity norm", Systems & Control Letters 15, 1990) in the form of Bruinsma and Steinbuch
/// ("A fast algorithm to compute the H-infinity norm of a transfer function matrix", Systems &
/// Control Letters 14, 1990). For the first-order realisation x' = F x + G u, y = L x
/// (F = E^-1 A, G = E^-1 B, L = C; ecmor models have no feedthrough term), gamma > 0 is a singular
/// value of the transfer matrix at omega exactly when i omega is an eigenvalue of the Hamiltonian
///     H(gamma) = [[F, G G' / gamma], [-L' L / gamma, -F']].
/// Its imaginary-axis eigenvalues therefore bound the frequency intervals where
/// sigma_max > gamma; the level is raised to the largest sigma_max at the intervals' midpoints
/// until no interval is left, which converges quadratically. With no feedthrough the transfer
/// matrix vanishes at omega -> infinity (second-order models too: (C + s Cv) (s^2 M + s D + K)^-1 B
/// decays like Cv M^-1 B / s), so the supremum is attained at a finite omega >= 0.
/// E (M) is never inverted unless it is diagonal (then E^-1 A is an exact row scaling): otherwise
/// the imaginary eigenvalues come from real QZ on the pencil
///     s [[E, 0], [0, E']] - [[A, B B' / gamma], [-C' C / gamma, -A']]
/// and sigma_max from a dense LU of s^2 M + s D + K (s E - A) per frequency, which keeps models
/// with an ill-conditioned mass matrix accurate (lf10, cond(M) = 2e6: 1.8e-5 -> 7e-14).
/// Dense O(n^3) per iteration (an eigenvalue problem of size 2n): for reduced models and small
/// full models through densify().

#include <string>

#include "ecmor/export.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

/// Options of hinf_norm and hinf_error_norm.
struct ECMOR_API HinfOptions {
  /// Relative tolerance of the result: on return (converged) the norm lies in
  /// [value, value (1 + 2 relative_tolerance)]. In (0, 0.1] and >= 1e-14; default 1e-10.
  double relative_tolerance = 1e-10;
  /// Largest number of level-set iterations (Hamiltonian eigenvalue problems), >= 1; default 50
  /// (the iteration converges quadratically: 3 to 8 are typical).
  Index max_iterations = 50;
  /// \throws ConfigError naming the field, the value and the rule.
  void validate() const;
};

/// Result of hinf_norm and hinf_error_norm. Not converging within max_iterations is a result
/// (converged = false, value a lower bound), not an exception.
struct ECMOR_API HinfResult {
  double value = 0.0;             ///< ||G||_Hinf (a lower bound, attained at omega_peak_rad_s)
  double upper_bound = 0.0;       ///< value (1 + 2 tol) when converged, +inf otherwise
  double omega_peak_rad_s = 0.0;  ///< a frequency where sigma_max(G(i omega)) = value, rad/s
  double f_peak_hz = 0.0;         ///< the same in Hz (omega / 2 pi)
  Index iterations = 0;           ///< Hamiltonian eigenvalue problems solved
  Index evaluations = 0;          ///< transfer-matrix evaluations (test frequencies, midpoints)
  bool converged = false;         ///< the level-set test certified the tolerance
  std::string method;             ///< "level set (Bruinsma-Steinbuch)"
  std::string message;            ///< how the iteration ended, with numbers
};

/// ||G||_Hinf of a dense model of either kind (through first_order_realization).
/// \throws InputError for an unstable model (naming the number of poles with Re >= 0 and the
///         one of largest real part, from ecmor::poles) or a numerically singular E (M);
///         ConfigError for invalid options.
ECMOR_API HinfResult hinf_norm(const ReducedModel& model, const HinfOptions& options = {});

/// ||Ga - Gb||_Hinf of two dense models of either kind with the same inputs and outputs, by the
/// same method on the block-diagonal realisation F = diag(Fa, Fb), G = [Ga; Gb], L = [La, -Lb].
/// The error is evaluated as Ga(i w) - Gb(i w), so it is accurate to about eps ||G|| in absolute
/// terms; a model against itself gives exactly 0. For a small full model use
/// hinf_error_norm(densify(full), reduced).
/// \throws InputError when the models' inputs or outputs differ, or as hinf_norm for either one.
ECMOR_API HinfResult hinf_error_norm(const ReducedModel& a, const ReducedModel& b,
                                     const HinfOptions& options = {});

}  // namespace ecmor
