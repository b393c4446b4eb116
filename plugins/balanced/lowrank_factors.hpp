#pragma once
/// \file lowrank_factors.hpp
/// The low-rank route to the Gramian factors of the balanced reducer (balanced.cpp): both factors
/// by ecmor's low-rank ADI (ecmor/gramians/lowrank_adi.hpp) through the model's FirstOrderView, so
/// a second-order model is solved with P(s) = s^2 M + s D + K of size N and no 2N matrix is formed.
/// The result fills the same GramianFactors as the dense route (gramian_factors.hpp), so the
/// truncation code does not know which route ran:
///     P ~ Zc Zc',   Q ~ Zq Zq' (ADI's observability factor),   E'QE ~ Zo Zo' with Zo = E' Zq.
/// Private to the plugin (and its tests).
#include <fmt/format.h>

#include <chrono>
#include <string>

#include "ecmor/base/error.hpp"
#include "ecmor/gramians/lowrank_adi.hpp"
#include "ecmor/gramians/quadrature.hpp"
#include "ecmor/linalg/first_order_view.hpp"
#include "ecmor/linalg/rigid_body.hpp"
#include "gramian_factors.hpp"

namespace ecmor::balanced {

/// What the two ADI runs (and, for band Gramians, the band quadrature) did, for the diagnostics,
/// the note and the refusal of an unconverged run.
struct AdiSummary {
  AdiResult controllability;  ///< without its factor (moved into GramianFactors::Zc)
  AdiResult observability;    ///< without its factor (moved into GramianFactors::Zq)
  bool band = false;          ///< band Gramians: the quadrature fields below are set
  bool quadrature_converged = true;
  Index quadrature_evaluations = 0;
  double quadrature_error = 0.0;  ///< error estimate relative to ||[L_B L_C]||_F
  double quadrature_seconds = 0.0;
  /// Both ADI runs met their tolerance and (band) the quadrature its own.
  bool converged() const {
    return controllability.converged && observability.converged && quadrature_converged;
  }
  /// "controllability: converged: residual ...; observability: not converged: ..."
  std::string text() const {
    return "controllability: " + controllability.message +
           "; observability: " + observability.message;
  }
};

/// Refuses an undamped second-order model (D = 0) before any iteration: every pole is then on the
/// imaginary axis, which is certain without computing one. (A damped model with an undamped mode
/// is caught by the ADI: no admissible shift, or a Ritz value on the axis that is an eigenvalue.)
inline void refuse_undamped(const FirstOrderView& view, const char* what) {
  if (const SecondOrderModel* so = view.so(); so != nullptr && so->D.norm() == 0.0) {
    throw InputError(fmt::format(
        "balanced: the {} do not exist: the second-order model is undamped (D = 0), so all its "
        "poles lie on the imaginary axis and the Lyapunov equations have no solution; add damping "
        "(e.g. Rayleigh damping alpha M + beta K) or use modal or krylov",
        what));
  }
}

/// A singular K of a second-order model means a pole at s = 0: a rigid-body mode of a
/// free-floating structure. The Gramians do not exist, and computed ones (whose rounding puts that
/// pole at +-1e-16) are dominated by it: the truncation would keep one state and report nothing
/// wrong. The rigid-body analysis (rigid_body_modes: the null space of K) names the number of
/// modes for symmetric K; otherwise one factorisation at s = 0 tells. (First-order models are left
/// to the Gramian solvers, whose messages name a singular E and the unstable poles; an integrator
/// with E regular is not caught here.)
/// \throws InputError naming the matrix, the number of rigid-body modes and the remedy.
inline void refuse_pole_at_zero(FirstOrderView& view, const Model& model) {
  if (!view.second_order()) return;
  const RigidBodyModes rigid = rigid_body_modes(model, view.solver());
  if (rigid.decided && rigid.count > 0) {
    throw InputError(fmt::format(
        "balanced: balanced truncation needs an asymptotically stable model; this one has {} "
        "rigid-body mode{} (K is singular, a pole at s = 0): its Gramians do not exist. Use modal "
        "(keeps the rigid-body modes) or krylov, or constrain the model (e.g. ground the free "
        "body). {}",
        rigid.count, rigid.count == 1 ? "" : "s", rigid.method));
  }
  if (rigid.decided) return;  // symmetric K: positive definite or no separated null space
  try {
    view.solver().factorize(Complex(0.0, 0.0));
  } catch (const NumericalError& e) {
    throw InputError(fmt::format(
        "balanced: the Gramians do not exist: K is singular, so the model has a pole at s = 0 "
        "(a rigid-body mode or an integrator) and is not asymptotically stable; constrain the "
        "model (e.g. ground the free body) or use modal or krylov ({})",
        e.what()));
  }
}

/// Both Gramian factors by low-rank ADI with one LowRankAdi, so the observability run reuses the
/// shift factorisations of the controllability run. An ADI run that stops at its budget is a
/// result (AdiSummary::converged() false, residual reported), not an exception: the caller
/// decides (balanced.cpp: warn, or refuse with adi_require_convergence).
/// \throws InputError from the ADI for an unstable model or a singular E / M (a DAE);
///         NumericalError for a breakdown, naming the shift and the iteration.
inline GramianFactors lowrank_gramian_factors(FirstOrderView& view, const AdiOptions& options,
                                              AdiSummary& summary) {
  const auto started = std::chrono::steady_clock::now();
  refuse_undamped(view, "Gramians");
  LowRankAdi adi(view, options);
  GramianFactors g;
  g.states = view.state_size();
  g.block_rows = view.second_order() ? view.size() : 0;
  try {
    summary.controllability = adi.solve(GramianSide::Controllability);
    summary.observability = adi.solve(GramianSide::Observability);
  } catch (const InputError& e) {
    throw InputError(fmt::format("balanced: the Gramians do not exist: {}", e.what()));
  } catch (const NumericalError& e) {
    throw NumericalError(fmt::format("balanced: low-rank ADI Gramians failed: {}", e.what()));
  }
  g.Zc = std::move(summary.controllability.Z);
  g.Zq = std::move(summary.observability.Z);
  summary.controllability.Z.resize(0, 0);
  summary.observability.Z.resize(0, 0);
  g.Zo = view.apply_e_transposed(g.Zq);
  // The ADI residuals are 2-norm ratios ||R||_2 / ||B B'||_2 of the uncompressed factors; the
  // compression changes the Gramian by at most compression_tolerance^2 relatively
  // (lowrank_adi.hpp).
  g.residual_c = summary.controllability.residual;
  g.residual_o = summary.observability.residual;
  g.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return g;
}

/// The frequency-limited Gramian factors on `band` by low-rank ADI with the band's indefinite
/// right-hand sides (lowrank_band_gramians, ecmor/gramians/lowrank_adi.hpp): L_B and L_C by
/// adaptive quadrature (one factorisation of P(i w) per node), then both ADI runs. A quadrature or
/// ADI run that misses its tolerance is reported in `summary`, as for the plain Gramians. \throws
/// as lowrank_gramian_factors, plus NumericalError for a pole on the imaginary axis in the
///         band (a quadrature node's factorisation fails).
inline GramianFactors lowrank_band_gramian_factors(FirstOrderView& view, const Band& band,
                                                   const AdiOptions& options,
                                                   const AdaptiveQuadratureOptions& quadrature,
                                                   AdiSummary& summary) {
  const auto started = std::chrono::steady_clock::now();
  refuse_undamped(view, "band Gramians");
  LowRankBandGramians bg;
  try {
    bg = lowrank_band_gramians(view, band, options, quadrature);
  } catch (const InputError& e) {
    throw InputError(fmt::format("balanced: the band Gramians do not exist: {}", e.what()));
  } catch (const NumericalError& e) {
    throw NumericalError(fmt::format("balanced: low-rank band Gramians failed: {}", e.what()));
  }
  GramianFactors g;
  g.states = view.state_size();
  g.block_rows = view.second_order() ? view.size() : 0;
  g.band_limited = true;
  g.Zc = std::move(bg.controllability.Z);
  g.Zq = std::move(bg.observability.Z);
  g.Zo = view.apply_e_transposed(g.Zq);
  g.residual_c = bg.controllability.residual;
  g.residual_o = bg.observability.residual;
  summary.controllability = static_cast<const AdiResult&>(bg.controllability);
  summary.observability = static_cast<const AdiResult&>(bg.observability);
  summary.controllability.Z.resize(0, 0);
  summary.observability.Z.resize(0, 0);
  summary.band = true;
  const MatrixQuadrature& q = bg.integrals.quadrature;
  summary.quadrature_converged = q.converged;
  summary.quadrature_evaluations = q.evaluations;
  const double size = q.integral.norm();
  summary.quadrature_error = size > 0.0 ? q.error_estimate / size : q.error_estimate;
  summary.quadrature_seconds = bg.quadrature_seconds;
  g.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return g;
}

}  // namespace ecmor::balanced
