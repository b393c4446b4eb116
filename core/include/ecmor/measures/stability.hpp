#pragma once
/// \file stability.hpp
/// Is the full model itself stable? A reduced model can meet its band tolerance and be stable
/// while the full model has a pole in the right half-plane outside the band (or on the imaginary
/// axis): in the band it is a faithful model, in the time domain it is not. The driver reports the
/// full model's stability next to the reduced model's so that a user is not misled by a stable
/// reduced model of an unstable structure.

#include <string>

#include "ecmor/export.hpp"
#include "ecmor/linalg/rigid_body.hpp"
#include "ecmor/model/model.hpp"

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

/// The same, with the rigid-body analysis of `model` already done (rigid_body_modes): the
/// structural test then uses it instead of factorising K again, and a singular K is reported with
/// its number of rigid-body modes.
ECMOR_API StabilityReport full_model_stability(const Model& model, Index dense_states,
                                               const RigidBodyModes& rigid);

/// Is a reduced model as stable as the full model? The one rule for every strategy, the driver's
/// summary and the optimisers' `stable_only`.
enum class ReducedVerdict {
  Asymptotic,     ///< every pole has Re < 0
  RigidLikeFull,  ///< poles at 0 from exactly the full model's rigid-body modes, the rest Re < 0
  /// poles at 0 from fewer rigid-body modes than the full model's, rest Re < 0: not accepted
  /// (the same count is required), kept apart from Unstable so that reports say what happened
  RigidSubset,
  Unstable,  ///< a pole with Re >= 0 away from 0, or more poles at 0 than the full model
};

struct ECMOR_API ReducedStability {
  ReducedVerdict verdict = ReducedVerdict::Unstable;
  /// Rigid-body modes of the reduced model (zero eigenvalues of (Kr, Mr), resp. poles at 0 of a
  /// descriptor model) and of the full model.
  Index rigid_modes = 0;
  Index full_rigid_modes = 0;
  /// Poles with Re >= 0 (or NaN) outside the disc |s| <= zero_radius: never allowed.
  Index right_poles = 0;
  /// Poles inside the disc |s| <= zero_radius: the rigid-body poles at s = 0 within the full
  /// model's tolerance, and any damped pole that small (e.g. s = -alpha of a rigid-body mode under
  /// Rayleigh damping alpha M + beta K). Not computed on the fast path (known_unstable == 0).
  Index zero_poles = 0;
  /// Radius of the disc around s = 0 whose poles count as rigid-body poles [rad/s]: sqrt of
  /// RigidBodyModes::zero_bound for a second-order full model, zero_bound for a descriptor one; 0
  /// when the full model has no rigid-body mode (then every pole with Re >= 0 is refused).
  double zero_radius = 0.0;
  /// The verdict in words for users: "asymptotically stable", "stable with 6 rigid-body modes like
  /// the full model", "not as stable as the full model: 3 of its 6 rigid-body modes", "unstable".
  std::string label;
  /// Why, with numbers ("2 poles with Re >= 0 away from s = 0, the largest real part 3.1e-02").
  std::string reason;
  /// Accepted as "as stable as the full model": Asymptotic or RigidLikeFull. RigidSubset is not:
  /// its remaining rigid-body modes are undamped poles at 0, but not the full model's count.
  bool accepted() const {
    return verdict == ReducedVerdict::Asymptotic || verdict == ReducedVerdict::RigidLikeFull;
  }
};

/// Judges `reduced` against the full model's rigid-body modes `full` (rigid_body_modes on the full
/// model). A reduced model is as stable as the full model when
///  * no pole lies in the closed right half-plane outside the disc |s| <= zero_radius (every
///    elastic pole is damped: Re < 0; NaN counts as not damped);
///  * its rigid-body modes are exactly the full model's (RigidLikeFull) or none (Asymptotic); fewer
///    is RigidSubset, not accepted, more is Unstable. For a second-order reduced model they are the
///    eigenvalues of (Kr, Mr) with |mu| <= full.zero_bound (by Cauchy interlacing a Galerkin
///    projection of symmetric K, M cannot have more than full.count of them, since the full
///    model's next eigenvalue lies above the gap), for a descriptor one the poles in the disc,
///    compared with full.zero_poles when the full model is second order;
///  * the poles in the disc with Re >= 0 are explained by those modes (at most 2 per rigid mode of
///    a second-order model, 1 of a descriptor model).
/// The disc is the full model's own gap (RigidBodyModes::zero_bound): rigid-body eigenvalues are
/// rounding-level, the first elastic one lies orders of magnitude above.
/// Without rigid-body modes in the full model, a zero eigenvalue of (Kr, Mr) is one below the
/// rounding floor kRigidFloor * full.scale, and the rule reduces to "every pole has Re < 0".
/// `known_unstable`: the number of poles with Re >= 0 when the caller has counted them (the band
/// error estimator does), -1 otherwise; 0 for a full model without rigid-body modes settles the
/// verdict without the eigenvalues (one Cholesky factorisation of Kr - bound Mr instead).
/// Never throws: a failing eigenvalue computation gives Unstable with the reason ("not shown
/// stable").
ECMOR_API ReducedStability reduced_model_stability(const ReducedModel& reduced,
                                                   const RigidBodyModes& full,
                                                   Index known_unstable = -1);

/// The finite eigenvalues of the pencil of densify(model) (cubic in the number of first-order
/// states; the caller bounds it). A pole counts as on the axis when |Re p| <= 1e-9 |p| (an
/// undamped mode: rounding leaves Re of order eps |p|, either sign), or as a pole at s = 0 when
/// A is singular (d = n - rank A by rank-revealing QR: the d poles of least modulus, and any
/// below 1e-6 of the largest). Size alone cannot tell a pole at 0 from a slow real pole:
/// descriptor models spread their poles over many decades. Sets max_real_pole.
ECMOR_API StabilityReport dense_model_stability(const Model& model);

}  // namespace ecmor
