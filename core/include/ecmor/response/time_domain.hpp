#pragma once
/// \file time_domain.hpp
/// Time-domain simulation of full (sparse) and reduced (dense) models from rest, and the output
/// error e(t) = y(t) - yr(t) (seed Eq. 11) with its L2 and max norms.
///
/// Schemes (one-step, implicit, A-stable, second order; the time step h = t_end / steps is fixed):
///  * Second-order models  M q'' + D q' + K q = B u,  y = C q + Cv q':
///      - Newmark: average acceleration (beta = 1/4, gamma = 1/2), i.e. the trapezoidal rule on the
///        first-order form; no numerical damping. Effective matrix  M + h/2 D + h^2/4 K.
///      - GeneralizedAlpha: Chung-Hulbert (J. Appl. Mech. 60, 1993) with spectral radius rho_inf at
///        h -> inf:  alpha_m = (2 rho - 1)/(rho + 1), alpha_f = rho/(rho + 1),
///        gamma = 1/2 - alpha_m + alpha_f, beta = (1 - alpha_m + alpha_f)^2 / 4.
///        Effective matrix (1 - alpha_m) M + (1 - alpha_f) gamma h D + (1 - alpha_f) beta h^2 K.
///  * Descriptor models  E x' = A x + B u,  y = C x:
///      - Newmark: the trapezoidal rule. Effective matrix E - h/2 A.
///      - GeneralizedAlpha: the first-order generalised-alpha method of Jansen, Whiting and Hulbert
///        (CMAME 190, 2000): alpha_m = (3 - rho)/(2 (1 + rho)), alpha_f = 1/(1 + rho),
///        gamma = 1/2 + alpha_m - alpha_f. Effective matrix alpha_m E - alpha_f gamma h A.
///    The trapezoidal rule is the same method as Newmark's average acceleration applied to the
///    first-order form, so a first-order reduced model of a second-order full model is simulated by
///    the same method (in exact arithmetic) as the full model under `Newmark`.
/// The effective matrix is factorised ONCE and reused for every step (one solve per step). The
/// consistent initial rate (acceleration q''(0) = M^-1 (B u(0+) - D q'(0+)), or
/// x'(0) = E^-1 (A x(0+) + B u(0+))) needs M^-1 (E^-1): M (E) is factorised once more, so a run
/// makes exactly 2 factorisations. A singular M or E (DAE) is refused with an InputError: neither
/// the consistent initial rate nor the impulse's initial state is defined without M^-1 (E^-1), and
/// the trapezoidal rule does not damp inconsistent algebraic components of an index-1 DAE.
///
/// The model starts at rest (q = q' = 0, x = 0) before t = 0. Inputs (u(t) for t > 0, with u(0)
/// taken as u(0+)):
///  * Step:    u(t) = amplitude.
///  * Impulse: u(t) = amplitude delta(t). Integrated over [0-, 0+] it sets the state at 0+:
///             q'(0+) = M^-1 B amplitude, q(0+) = 0 (second order); x(0+) = E^-1 B amplitude
///             (descriptor); then u = 0 for t > 0. y(0) is reported as y(0+).
///  * Chirp:   u(t) = amplitude sin(2 pi (f0 t + (f1 - f0) t^2 / (2 t_end))), a LINEAR sweep of the
///             instantaneous frequency from f0 at t = 0 to f1 at t = t_end (Hz).
/// The input acts on one column of B (input >= 0) or on all inputs at once (input = -1).

#include <string>
#include <vector>

#include "ecmor/base/types.hpp"
#include "ecmor/export.hpp"
#include "ecmor/linalg/shifted_solver.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

/// The input signal u(t) (see the file comment for the formulas).
struct ECMOR_API InputSignal {
  enum class Kind { Step, Impulse, Chirp };
  Kind kind = Kind::Step;
  /// Amplitude (units of u; for Impulse the area of the delta). Finite and non-zero.
  double amplitude = 1.0;
  /// 0-based column of B driven by the signal, or -1 (default): every input at once
  /// (u = signal * ones(m)). Checked against the model by simulate().
  Index input = -1;
  /// Chirp only: start and end frequency of the linear sweep in Hz; finite and > 0 (f1 < f0, a
  /// downward sweep, is allowed).
  double f0_hz = 1.0;
  double f1_hz = 10.0;

  /// u(t) for t > 0, and u(0+) at t = 0 (Impulse: 0; the delta is handled by the initial
  /// state). t_end is needed by the chirp's sweep rate.
  double value(double t, double t_end) const;
  /// \throws ConfigError naming field, value and rule ("InputSignal::amplitude = nan: must be
  ///         finite and non-zero").
  void validate() const;
};
ECMOR_API std::string to_string(InputSignal::Kind kind);
/// "step", "impulse", "chirp". \throws ConfigError listing the valid names.
ECMOR_API InputSignal::Kind parse_input_kind(const std::string& name);

/// Options of the fixed-step time integration.
struct ECMOR_API TimeIntegrationOptions {
  enum class Scheme { Newmark, GeneralizedAlpha };
  /// End time in seconds (the run covers [0, t_end]); finite and > 0.
  double t_end = 1.0;
  /// Number of steps, h = t_end / steps; in [1, 1e9].
  Index steps = 1000;
  /// Newmark (average acceleration / trapezoidal; default) or GeneralizedAlpha.
  Scheme scheme = Scheme::Newmark;
  /// GeneralizedAlpha only: spectral radius at infinite step, in [0, 1] (1: no numerical
  /// damping; 0: asymptotic annihilation of the highest modes). Default 1.
  double rho_inf = 1.0;

  double step() const { return t_end / static_cast<double>(steps); }
  /// \throws ConfigError naming field, value and rule ("TimeIntegrationOptions::steps = 0: must be
  ///         >= 1").
  void validate() const;
};
ECMOR_API std::string to_string(TimeIntegrationOptions::Scheme scheme);
/// "newmark" (alias "trapezoidal"), "generalized-alpha". \throws ConfigError listing the names.
ECMOR_API TimeIntegrationOptions::Scheme parse_scheme(const std::string& name);

/// Outputs sampled at t_k = k h, k = 0..steps.
struct ECMOR_API TimeResponse {
  std::vector<double> t;     ///< steps + 1 times [s]
  Matrix y;                  ///< p x (steps + 1) outputs
  double dt = 0.0;           ///< step h [s]
  Index factorizations = 0;  ///< numeric factorisations made (2: effective matrix and M or E)
  Index solves = 0;          ///< right-hand-side columns solved
  double seconds = 0.0;      ///< wall time of the run (factorisations included)
  std::string scheme;        ///< the scheme in words, with its parameters
};

/// Simulates a full (sparse) model with the given solver (bound to this model; see
/// make_shifted_solver). Factorises the effective matrix once (and M or E once).
/// \throws ConfigError for invalid options or an input index out of range; InputError for a
///         singular M or E or a solver not bound to a model of this size; NumericalError when the
///         effective matrix is singular or the solution becomes non-finite.
ECMOR_API TimeResponse simulate(const Model& model, ShiftedSolver& solver, const InputSignal& input,
                                const TimeIntegrationOptions& options);

/// Simulates a reduced (dense) model by the same scheme, with dense LU factorisations (once).
/// \throws as the sparse simulate (a singular Mr or Er: InputError).
ECMOR_API TimeResponse simulate(const ReducedModel& model, const InputSignal& input,
                                const TimeIntegrationOptions& options);

/// A time span and step count that show a response: where its transient happens, not a flat line.
struct ECMOR_API TimeSpan {
  double t_end = 0.0;       ///< [s]
  Index steps = 0;          ///< before any cap the caller applies
  double f_fast_hz = 0.0;   ///< the fastest relevant dynamics, resolved by 20 steps per period
  double tau_slow = 0.0;    ///< slowest decay time constant that matters [s]; 0: none found
  bool from_poles = false;  ///< false: the band's defaults (5 / f_min, 20 steps per 1 / f_max)
  std::string reason;       ///< how it was chosen, for the user
};

/// The span of a step or impulse response of `model` over the band [f_min, f_max] Hz, chosen from
/// its poles: the modal terms (R_i / p_i) e^(p_i t) of the response (R_i the residue of pole p_i;
/// for an impulse R_i e^(p_i t)) whose amplitude is at least 1e-3 of the largest matter;
/// t_end = 5 tau of the slowest of them (e^-5: 0.7 % of the term left), at most 5 / f_min, and 20
/// steps per period of the fastest of them (|p| / 2 pi), at most f_max, at least 200 steps.
/// Falls back to the band's defaults (5 periods of f_min, 20 steps per period of f_max) when M_r
/// (E_r) is singular, or when a term that matters does not decay (a rigid-body mode, an undamped
/// or unstable pole): that response does not settle. A chirp keeps the band's defaults.
ECMOR_API TimeSpan suggest_time_span(const ReducedModel& model, InputSignal::Kind input,
                                     double f_min_hz, double f_max_hz);

/// The output error e(t) = y(t) - yr(t) (seed Eq. 11) and its norms.
struct ECMOR_API OutputError {
  Matrix e;  ///< p x (steps + 1)
  /// L2 norm: sqrt(integral_0^t_end ||e(t)||_2^2 dt), trapezoidal rule on the time grid.
  double l2 = 0.0;
  /// Max norm: max over the grid and the outputs of |e_i(t_k)| (the infinity norm in space).
  double max = 0.0;
  /// The same norms of the full model's output y.
  double y_l2 = 0.0;
  double y_max = 0.0;
  /// l2 / y_l2 and max / y_max; NaN when the norm of y is zero (relative_defined = false).
  double relative_l2 = 0.0;
  double relative_max = 0.0;
  bool relative_defined = true;
  double t_max = 0.0;  ///< time at which the max norm is attained
};

/// e = full.y - reduced.y on the common grid.
/// \throws InputError when the grids (number of samples, or any time differing by more than
///         1e-12 t_end) or the output counts differ.
ECMOR_API OutputError output_error(const TimeResponse& full, const TimeResponse& reduced);

}  // namespace ecmor
