#pragma once
/// \file stability.hpp
/// Is the full model itself stable? A reduced model can meet its band tolerance and be stable
/// while the full model has a pole in the right half-plane outside the band (or on the imaginary
/// axis): in the band it is a faithful model, in the time domain it is not. The driver reports the
/// full model's stability next to the reduced model's so that a user is not misled by a stable
/// reduced model of an unstable structure.

#include <string>

#include "ecmor/export.hpp"
#include "ecmor/model.hpp"

namespace ecmor {

enum class Stability {
  Asymptotic,  ///< every finite pole has Re < 0
  Marginal,    ///< no pole with Re > 0, but some on the imaginary axis (undamped, rigid-body)
  Unstable,    ///< a pole with Re > 0
  Unknown,     ///< too large for the dense check and not decidable from the matrices' structure
};

ECMOR_API std::string to_string(Stability s);

struct StabilityReport {
  Stability verdict = Stability::Unknown;
  /// How it was decided ("dense eigenvalues of the 60 x 60 pencil", "Cholesky of K and D", ...),
  /// and for Marginal/Unstable why, in words.
  std::string method;
  std::string reason;
  /// The largest real part of a finite pole (dense check only; NaN otherwise).
  double max_real_pole = 0.0;
  bool dense = false;
};

/// Decides the stability of a full model:
///  * a second-order model with M, D, K symmetric (M is positive definite, a load-time rule), by
///    the inertia of K and D (sparse Cholesky): K not positive definite means a pole at s = 0
///    (K singular: Marginal) or in the right half-plane (K indefinite: Unstable); D = 0 with K
///    positive definite means every pole on the axis (Marginal); K and D positive definite mean
///    asymptotic stability (energy argument). Any other second-order model (unsymmetric K or D,
///    D only semidefinite) goes on to the dense check;
///  * with at most `dense_states` first-order states (N, or 2N for second order):
///    dense_model_stability(model);
///  * else Unknown.
/// Never throws for a valid model: a failing dense eigenvalue iteration gives Unknown with the
/// reason.
ECMOR_API StabilityReport full_model_stability(const Model& model, Index dense_states);

/// The finite eigenvalues of the pencil of densify(model) (cubic in the number of first-order
/// states; the caller bounds it). A pole counts as on the axis when |Re p| <= 1e-9 |p| (an
/// undamped mode: rounding leaves Re of order eps |p|, either sign), or as a pole at s = 0 when
/// A is singular (d = n - rank A by rank-revealing QR: the d poles of least modulus, and any
/// below 1e-6 of the largest). Size alone cannot tell a pole at 0 from a slow real pole:
/// descriptor models spread their poles over many decades. Sets max_real_pole.
ECMOR_API StabilityReport dense_model_stability(const Model& model);

}  // namespace ecmor
