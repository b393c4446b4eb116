#pragma once
/// \file rigid_body.hpp
/// Rigid-body modes of a full model: the null space of K (second order, M q'' + D q' + K q = B u)
/// or of A (a symmetric descriptor model E x' = A x + B u with E positive definite). A rigid-body
/// mode is a vector that K annihilates; it gives the model a pole at s = 0. This is the one
/// implementation that `ecmor info`, the modal reducer and the stability rule
/// (reduced_model_stability in stability.hpp) use.
///
/// Why not a relative eigenvalue threshold alone (|lambda| <= tol * max_i K_ii / M_ii): long or
/// soft structures have a condition number above 1e8 and their lowest elastic mode falls below any
/// such threshold (the anchored triple chain with N = 1e5 has its lowest mode at 8.66e-6 Hz,
/// lambda / (max K_ii / M_ii) ~ 1e-10), while a free body's rigid-body eigenvalues come out
/// anywhere from 1e-16 to 1e-8 of that scale (rounding of the assembly, or matrices written with
/// 7-8 significant digits). The decision is therefore made in two steps:
///  1. a sparse Cholesky factorisation of K (CHOLMOD, after Jacobi scaling; is_positive_definite).
///     If it succeeds with a pivot ratio above N eps, K is positive definite: no rigid-body mode,
///     however small the lowest eigenvalue;
///  2. otherwise the lowest eigenvalues of K phi = lambda M phi by shift-invert Lanczos (ARPACK) at
///     a shift sigma < 0 (K - sigma M is positive definite for a singular K), and a gap test: the
///     rigid-body modes are the eigenvalues below the largest gap, by ratio, between consecutive
///     eigenvalues |lambda_j| (each raised to the rounding floor kRigidFloor * scale), provided
///     that gap is at least kRigidGap and the eigenvalues below it are at most kRigidCeiling *
///     scale. A negative eigenvalue beyond the floor means K is indefinite (a real pole s > 0), not
///     singular.

#include <limits>
#include <string>

#include "ecmor/export.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

/// Rounding floor of a computed zero eigenvalue, relative to the spectrum scale max_i K_ii / M_ii:
/// K r for a rigid-body vector r sums about 100 terms of size |K_ij r_j| per row with relative
/// rounding eps each, so |lambda| of a rigid-body mode is up to ~1e2 eps ~ 1e-14 of the scale; the
/// floor sits a decade above. Eigenvalues below it are indistinguishable from 0.
constexpr double kRigidFloor = 1e-13;
/// Largest eigenvalue, relative to the same scale, that can still be a rigid-body mode: sqrt(eps)
/// ~ 1.5e-8 covers matrices stored with 8 significant digits; 1e-6 leaves a margin for 7.
constexpr double kRigidCeiling = 1e-6;
/// Smallest ratio between the first elastic eigenvalue and the largest rigid-body one (each at
/// least the floor) that counts as a gap. Measured: free 3-D solids 6.3e7 (N = 2 460) and 1.5e8
/// (N = 1 116), a free chain of 1e5 masses 3.9e3; a smooth spectrum has neighbouring ratios near 1.
constexpr double kRigidGap = 1e3;

/// What rigid_body_modes() found.
struct ECMOR_API RigidBodyModes {
  /// true when a test applied (K, resp. A and E, symmetric; M, resp. E, positive definite), false
  /// otherwise (unsymmetric matrices: no rigid-body analysis; count is 0 and not a finding).
  bool decided = false;
  /// true when K (-A) has a negative eigenvalue beyond the rounding floor: the model has a real
  /// pole s > 0 (negative stiffness), not a null space. count is then 0.
  bool indefinite = false;
  /// true for a second-order model (K, M), false for a descriptor one (-A, E).
  bool second_order = true;
  /// true when step 1 decided: the Cholesky factorisation of K (-A) succeeded.
  bool positive_definite = false;
  /// dim null(K) (second order) or dim null(A) (descriptor): the number of rigid-body modes.
  Index count = 0;
  /// Algebraic multiplicity of the pole s = 0 of the full model: second order 2 count -
  /// rank(N' D N) for the M-orthonormal null-space basis N (each rigid mode gives one pole at 0
  /// when it is damped, D N != 0, and two when it is not); descriptor: count.
  Index zero_poles = 0;
  /// N x count, M-orthonormal (E-orthonormal) basis of the null space (empty when count == 0).
  Matrix basis;
  /// The computed eigenvalues of the rigid-body modes (count entries; rounding-level values).
  Vector rigid_eigenvalues;
  /// An eigenvalue of (K, M) with |lambda| <= zero_bound is a zero eigenvalue [1/s^2 for second
  /// order, 1/s for descriptor models]: the geometric mean across the gap, sqrt(largest rigid *
  /// first elastic) with the rigid one raised to the floor. 0 when count == 0. By Cauchy
  /// interlacing a Galerkin reduced model (W = V) has at most `count` eigenvalues below it.
  double zero_bound = 0.0;
  /// The lowest eigenvalue above the gap (NaN when not computed, e.g. decided by Cholesky).
  double first_elastic = std::numeric_limits<double>::quiet_NaN();
  /// The spectrum scale max_i K_ii / M_ii.
  double scale = 1.0;
  /// How it was decided, in words ("Cholesky of K succeeded: K is positive definite", ...).
  std::string method;
  /// "6 rigid-body modes (K is singular; ...)", "no rigid-body mode (...)", for messages.
  std::string describe() const;
};

/// max_i |A_ii| / B_ii over the positive B_ii: Rayleigh quotients of unit vectors, a lower bound
/// of the largest eigenvalue of the pencil (A, B) and the scale against which an eigenvalue counts
/// as zero (kRigidFloor); 1 when no B_ii is positive.
ECMOR_API double spectrum_scale(const SparseMatrix& A, const SparseMatrix& B);

/// The rigid-body modes of `model` (see the file comment), using `solver` (built on `model`) for
/// the shift-invert factorisation when step 2 is needed. The last decided result is remembered,
/// keyed by a fingerprint of the model's matrices: the driver, the reducer and the stability
/// report of one run share one analysis. Never throws for a valid model with a symmetric positive
/// definite M (E), except Interrupted (a stop request inside the eigensolver): a failing
/// eigensolver is reported through method with decided = false.
ECMOR_API RigidBodyModes rigid_body_modes(const Model& model, ShiftedSolver& solver);

/// The same with a solver of its own (the default backend).
ECMOR_API RigidBodyModes rigid_body_modes(const Model& model);

}  // namespace ecmor
