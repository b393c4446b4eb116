#pragma once
/// \file band_error.hpp
/// Error measures over a frequency band [f_min, f_max] in Hz (seed Eqs. 20-23), omega = 2 pi f:
///  * relative spectral error  eps2(f) = ||H - Hr||_2 / ||H||_2   (Eq. 22)
///  * relative Frobenius error epsF(f) = ||H - Hr||_F / ||H||_F   (Eq. 23)
///  * band H-infinity of the error: sup_f ||H - Hr||_2               (Eq. 20)
///  * band H2 of the error, squared: 2 * integral_{f_min}^{f_max} ||H - Hr||_F^2 df
///    = (1/2pi) * integral over omega in +-[omega_min, omega_max] of ||H - Hr||_F^2 domega.
///    The seed's Eq. 21 prints the unsquared norm under the integral; we use the squared norm,
///    the standard definition, which tends to the full H2 norm squared (Eq. 16) as the band
///    grows to [0, inf). Integrated by the trapezoidal rule in f on the sampled frequencies.
///
/// The tolerance is on the supremum over the band, not over a grid: the estimator samples a
/// log-spaced grid, adds the imaginary parts of the reduced model's poles inside the band
/// (resonances of lightly damped structures), then refines around the largest local maxima of the
/// relative error by golden-section search in log f. Where ||H(f)|| vanishes (a zero of H), the
/// relative error is undefined: such frequencies are excluded from the supremum and reported.
///
/// Two ways to obtain the full model's side of the comparison (BandErrorOptions::verify):
///  * dense: every sample is a full-model response H(i 2 pi f): one sparse factorisation per
///    frequency (cached), ~250 per evaluation and ~860 for the re-check;
///  * estimate: a reference model (reference_model.hpp), grown from the full solves already paid
///    for, stands in for H at every sample that has no full solve. Full solves are spent only at
///    the estimate's largest local maxima, a small random set in log f and the band edges; a
///    model is accepted on the full-model errors there (never on a pure estimate), and the
///    estimate's effectivity (estimate / true) at those frequencies is reported.
///    docs/error-measures.md#the-estimator has the algorithm and its measured effectivity.

#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "ecmor/export.hpp"
#include "ecmor/model/band.hpp"
#include "ecmor/model/model.hpp"
#include "ecmor/response/frequency_response.hpp"

namespace ecmor {

template <class O>
class OptionSpecs;

enum class ErrorNorm { Spectral, Frobenius };
/// "spectral", "frobenius": the names of YAML target.norm and of the APIs.
ECMOR_API const std::vector<std::pair<std::string, ErrorNorm>>& error_norm_names();
ECMOR_API std::string to_string(ErrorNorm norm);
/// Parses a name of error_norm_names(). \throws ConfigError listing the valid names.
ECMOR_API ErrorNorm parse_error_norm(const std::string& name);

/// Norm of a (small, dense) complex matrix: largest singular value or Frobenius norm.
ECMOR_API double matrix_norm(const ComplexMatrix& A, ErrorNorm norm);

/// How the full model's response is obtained for the band error (YAML error.verify).
enum class ErrorVerify {
  Dense,     ///< every sample is a full-model response (a factorisation per frequency)
  Estimate,  ///< a reference model estimates; full solves only where the estimate peaks
  Auto,      ///< Dense when N <= dense_max_states, else Estimate until it costs more than Dense
};
/// "dense", "estimate", "auto": the names of YAML error.verify.
ECMOR_API const std::vector<std::pair<std::string, ErrorVerify>>& error_verify_names();
ECMOR_API std::string to_string(ErrorVerify verify);
/// Parses a name of error_verify_names(). \throws ConfigError listing the valid names.
ECMOR_API ErrorVerify parse_error_verify(const std::string& name);

/// The band error's options. Each field's meaning, rule and YAML key (section `error`) are stated
/// once, in specs(); the values here are the defaults (dense_max_states = 0: the measured choice
/// of docs/error-measures.md).
struct ECMOR_API BandErrorOptions {
  ErrorNorm norm = ErrorNorm::Spectral;  ///< YAML target.norm
  Index grid_points = 200;
  bool pole_samples = true;
  Index max_pole_samples = 400;
  Index refine_peaks = 5;
  Index refine_evaluations = 40;
  double zero_threshold = 1e-13;
  ErrorVerify verify = ErrorVerify::Auto;
  Index dense_max_states = 0;
  Index estimate_points = 400;  ///< estimate mode from here on
  Index reference_points = 6;
  Index check_peaks = 4;
  Index random_checks = 2;
  Index check_rounds = 3;
  Index probe_solves = 1;

  /// The options' keys, rules and documentation (options.hpp).
  static const OptionSpecs<BandErrorOptions>& specs();
  /// \throws ConfigError "BandErrorOptions: <key> = <value>: <rule>" (by specs()).
  void validate() const;
};

/// One evaluation of the error of a reduced model over the band.
struct ECMOR_API BandError {
  double sup_relative = 0.0;   ///< sup over the sampled band of the chosen relative error
  double f_peak_hz = 0.0;      ///< where it peaks
  double hinf_absolute = 0.0;  ///< band H-infinity of H - Hr (Eq. 20), sampled
  double f_hinf_hz = 0.0;
  double h2_absolute = 0.0;  ///< sqrt of the band H2 norm squared of H - Hr (see file comment)
  ErrorNorm norm = ErrorNorm::Spectral;

  /// All sampled frequencies, ascending, with their errors.
  std::vector<double> f_hz;
  std::vector<double> relative;  ///< relative error in the chosen norm (NaN where undefined)
  std::vector<double> relative_spectral;
  std::vector<double> relative_frobenius;
  std::vector<double> absolute;        ///< ||H - Hr||_2
  std::vector<double> reference;       ///< ||H||_2
  std::vector<double> undefined_f_hz;  ///< where H vanishes (relative error undefined)

  Index grid_samples = 0, pole_samples = 0, refinement_samples = 0;
  bool reduced_singular = false;  ///< Hr hit a pole exactly at a sample (error reported as inf)
  /// Reduced poles with Re >= 0 (or NaN), when evaluate() computed the poles for its pole samples;
  /// -1 when they were not computed. Spares callers a second eigen-decomposition.
  Index unstable_poles = -1;

  /// Per sample: 1 where the error was measured against the full model's own H, 0 where
  /// against the reference model's estimate of it (estimate mode).
  std::vector<char> exact;
  /// Estimate mode: sup of the estimated relative error over the samples without a full solve
  /// (NaN in dense mode, where every sample is exact).
  double estimate_sup = std::numeric_limits<double>::quiet_NaN();
  bool estimated = false;     ///< sup_relative includes estimated samples (not a certified value)
  Index checked_samples = 0;  ///< samples measured against the full model (estimate mode)
  Index new_full_solves = 0;  ///< full-model responses this evaluation computed
  Index reference_order = 0;  ///< order of the reference model used (estimate mode)
  /// Estimate mode: the reference model's own evaluation error where the full model was solved
  /// (it interpolates there in exact arithmetic): estimates below it are rounding.
  double reference_floor = 0.0;
  /// Effectivity = estimate / true at the frequencies this evaluation checked with a full solve,
  /// the estimate taken before the solve (NaN when none).
  Index effectivity_count = 0;
  double effectivity_min = std::numeric_limits<double>::quiet_NaN();
  double effectivity_median = std::numeric_limits<double>::quiet_NaN();
  double effectivity_max = std::numeric_limits<double>::quiet_NaN();

  /// True when sup_relative <= tolerance and no estimated sample exceeds it.
  bool within(double tolerance) const;
  /// How the band was sampled, e.g. "200 log grid + 12 poles + 50 refinement".
  std::string sampling() const;
};

/// The frequencies of the `count` largest local maxima of error.relative, largest first: samples
/// at least as large as their left neighbour and larger than their right one (the last of a
/// plateau), above `above`. An undefined (NaN) sample is neither a maximum nor a neighbour that
/// blocks one. Where strategies place points and the estimator checks.
ECMOR_API std::vector<double> largest_local_maxima_hz(const BandError& error, Index count,
                                                      double above = -1.0);

namespace detail {
class EstimateEngine;
struct ReferenceValues;
}  // namespace detail

/// Evaluates band errors of reduced models against a (cached) full model.
class ECMOR_API BandErrorEstimator {
 public:
  /// Dense mode samples the options' grid of the full model here; estimate mode seeds the
  /// reference model with options.reference_points full solves. Both poll check_interrupt().
  BandErrorEstimator(ResponseCache& full, Band band, BandErrorOptions options);
  ~BandErrorEstimator();
  BandErrorEstimator(const BandErrorEstimator&) = delete;
  BandErrorEstimator& operator=(const BandErrorEstimator&) = delete;
  /// Error of `reduced` over the band with the options' sampling.
  BandError evaluate(const ReducedModel& reduced);
  /// Error on exactly the given frequencies (no refinement, no pole samples).
  BandError evaluate_on(const ReducedModel& reduced, const std::vector<double>& f_hz);
  /// Re-check on an independent grid: `factor` times denser than the options' grid, offset so that
  /// no frequency coincides with it, plus refinement of its own local maxima; the largest errors
  /// are re-evaluated with a dense LU of P_r(s), independently of the fast Hessenberg path.
  BandError verify(const ReducedModel& reduced, Index factor = 4);
  /// The re-check of a model derived from `neighbour`, a model that passed verify() with the
  /// error `neighbour_error` (a compression of it, say), at no more than `max_new_solves` new
  /// full solves. The candidate's departure from the neighbour, d(f) = ||Hn - Hc|| / ||Hn||, is
  /// sampled at the reduced level on the options' grid and both models' pole frequencies in the
  /// band, and its local maxima are refined (golden section, no full solve). Where
  /// e_n + (1 + e_n) d(f) <= tolerance, the triangle inequality bounds the candidate's error by
  /// the tolerance. At the largest maxima above that (largest first, at most max_new_solves) the
  /// full model is solved. The candidate is then compared with the full model as in verify():
  /// dense mode on verify()'s grid, the frequencies solved so far and those new ones (no
  /// refinement of the true error: that is what the departure's maxima stand in for); estimate
  /// mode as EstimateEngine::verify_at. `new_full_solves` counts the solves made: at most
  /// max_new_solves once verify()'s grid is solved (a verify() of the neighbour solved it; dense
  /// mode solves what is missing of it, as verify() would).
  /// \throws ConfigError for factor < 1, max_new_solves < 0 or a tolerance that is not > 0.
  BandError verify_near(const ReducedModel& reduced, const ReducedModel& neighbour,
                        double neighbour_error, double tolerance, Index factor,
                        Index max_new_solves);

  /// Estimate mode: adds the columns of a candidate's basis (V or W, N rows) to the reference
  /// model, so that the reference is at least as rich as the candidates it judges. Ignored in
  /// dense mode and for bases that do not have N rows (a first-order basis of a second-order
  /// model).
  void offer_basis(const Matrix& basis);
  /// The resolved mode: Dense or Estimate (Dense after a switch, see switch_note()).
  ErrorVerify mode() const { return m_engine ? ErrorVerify::Estimate : ErrorVerify::Dense; }
  /// Auto mode, after it left the estimate for the dense sampling: when and why (else empty).
  const std::string& switch_note() const { return m_switch_note; }
  /// Leaves the estimate mode for good (no-op in dense mode): samples the full model on the grid
  /// now; later evaluations are dense. `reason` becomes switch_note(). Auto mode calls it when
  /// the estimate has cost more than the dense mode would; under MPI, call it on every rank.
  void use_dense(std::string reason);
  /// Estimate mode: a strategy about to end without a passing model because its estimated error
  /// stopped improving (`why`) asks for more effort on the error. The estimate may be what stalls
  /// it: a reference model that overestimates between its solves hides the candidates' progress
  /// and points the search at its own weak spots. Under `verify: auto` the dense mode is taken
  /// (use_dense) when its grids cost no more than the run has spent so far on full solves and the
  /// reference: the run's cost at most doubles. Otherwise (a large model, whose full solves are
  /// what the estimate saves, or `verify: estimate`) the estimate probes more: probe_solves grows
  /// by kEscalatedProbes, once per run (not when the user set it to 0). Returns whether anything
  /// changed; false in dense mode and once both steps were taken. Collective under MPI.
  /// escalation_note() says what was done.
  bool escalate(const std::string& why);
  /// The probe escalation (see escalate()): when and why (else empty; a switch to the dense mode
  /// is in switch_note()).
  const std::string& escalation_note() const { return m_escalation_note; }
  /// Full solves escalate() adds to probe_solves.
  static constexpr Index kEscalatedProbes = 2;
  /// Order of the reference model (0 in dense mode).
  Index reference_order() const;
  /// Wall time spent in this estimator so far: its construction (the dense grid or the reference's
  /// seed solves), evaluate, evaluate_on, verify, offer_basis and a switch to the dense mode, the
  /// full solves they make included. What a run spends on judging its candidates.
  double seconds() const { return m_seconds; }
  /// Of seconds(), the estimate mode's reference model: taking bases and solves into it, its
  /// Hessenberg form, poles and values (0 in dense mode). The work the dense mode does not do;
  /// with the full solves (ResponseCache::seconds()) it is what error control itself costs.
  double reference_seconds() const;

  const Band& band() const { return m_band; }
  const BandErrorOptions& options() const { return m_options; }
  const std::vector<double>& grid() const { return m_grid; }

 private:
  BandError assemble(const ReducedModel& reduced, std::vector<double> f_hz, Index grid, Index poles,
                     bool refine, bool dense_peaks);
  // verify()'s grid: the band edges and the midpoints of a grid `factor` times the options'.
  std::vector<double> verify_grid(Index factor) const;
  std::function<detail::ReferenceValues(const std::vector<double>&)> full_source();
  // Dense mode from here on: the full model on the whole grid, and the scales taken from it.
  void start_dense();
  // Auto mode: leaves the estimate once its own work exceeds what the dense sampling would cost.
  void consider_switch(Index verify_factor);
  // Adds an estimate-mode evaluation's excess cost over the dense mode's to the rent; returns e.
  BandError rented(BandError e, double overhead_before);
  double cost_per_full_solve() const;  // in flops of reference work; 0: not counted
  // The dense mode's grid and re-check grid, in full solves at per_solve flops each.
  double dense_purchase(double per_solve, Index verify_factor) const;
  ResponseCache& m_full;
  Band m_band;
  BandErrorOptions m_options;
  std::vector<double> m_grid;
  // Largest ||H||_2 and ||H||_F on the fixed grid: the scale of "H vanishes". Taken from the grid
  // only, so that a sample next to a lightly damped resonance cannot inflate it.
  double m_scale2 = 0.0;
  double m_scaleF = 0.0;
  std::unique_ptr<detail::EstimateEngine> m_engine;  // estimate mode only
  std::string m_escalation_note;
  Index m_evaluations = 0;    // evaluate/evaluate_on/verify calls so far
  double m_rent_flops = 0.0;  // auto mode: the estimate's cost over the dense mode's so far
  std::string m_switch_note;
  double m_seconds = 0.0;                   // see seconds()
  int m_timing = 0;                         // depth of the WallTimers on m_seconds
  double m_reference_seconds_before = 0.0;  // the reference's, before a switch to dense
};

}  // namespace ecmor
