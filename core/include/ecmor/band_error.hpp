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

#include <string>
#include <vector>

#include "ecmor/export.hpp"
#include "ecmor/frequency_response.hpp"
#include "ecmor/model.hpp"

namespace ecmor {

/// A frequency band in Hz.
struct ECMOR_API Band {
  double f_min_hz = 0.0;
  double f_max_hz = 0.0;
  /// \throws ConfigError unless 0 < f_min_hz < f_max_hz and both finite.
  void validate() const;
};

enum class ErrorNorm { Spectral, Frobenius };
ECMOR_API std::string to_string(ErrorNorm norm);
/// Parses "spectral" | "frobenius". \throws ConfigError listing the valid names.
ECMOR_API ErrorNorm parse_error_norm(const std::string& name);

/// Norm of a (small, dense) complex matrix: largest singular value or Frobenius norm.
ECMOR_API double matrix_norm(const ComplexMatrix& A, ErrorNorm norm);

struct ECMOR_API BandErrorOptions {
  ErrorNorm norm = ErrorNorm::Spectral;  ///< which relative error the supremum is taken of
  Index grid_points = 200;     ///< initial log-spaced samples over the band, >= 2
  bool pole_samples = true;    ///< also sample at Im(p)/2pi of reduced poles inside the band
  Index max_pole_samples = 400;///< at most this many pole samples (the least damped first)
  Index refine_peaks = 5;      ///< local maxima refined per evaluation, >= 0
  /// Golden-section steps per refined peak at most, >= 0; a peak stops earlier once its value has
  /// not risen (by 1e-4 relative) for 6 steps or its bracket is below 1e-9 relative in f.
  Index refine_evaluations = 40;
  /// ||H(f)|| <= zero_threshold * max_f ||H|| means "H vanishes here": relative error undefined.
  double zero_threshold = 1e-13;
  /// \throws ConfigError naming the field, value and rule.
  void validate() const;
};

/// One evaluation of the error of a reduced model over the band.
struct ECMOR_API BandError {
  double sup_relative = 0.0;  ///< sup over the sampled band of the chosen relative error
  double f_peak_hz = 0.0;     ///< where it peaks
  double hinf_absolute = 0.0; ///< band H-infinity of H - Hr (Eq. 20), sampled
  double f_hinf_hz = 0.0;
  double h2_absolute = 0.0;   ///< sqrt of the band H2 norm squared of H - Hr (see file comment)
  ErrorNorm norm = ErrorNorm::Spectral;

  /// All sampled frequencies, ascending, with their errors.
  std::vector<double> f_hz;
  std::vector<double> relative;   ///< relative error in the chosen norm (NaN where undefined)
  std::vector<double> relative_spectral;
  std::vector<double> relative_frobenius;
  std::vector<double> absolute;   ///< ||H - Hr||_2
  std::vector<double> reference;  ///< ||H||_2
  std::vector<double> undefined_f_hz;  ///< where H vanishes (relative error undefined)

  Index grid_samples = 0, pole_samples = 0, refinement_samples = 0;
  bool reduced_singular = false;  ///< Hr hit a pole exactly at a sample (error reported as inf)
  /// Reduced poles with Re >= 0 (or NaN), when evaluate() computed the poles for its pole samples;
  /// -1 when they were not computed. Spares callers a second eigen-decomposition.
  Index unstable_poles = -1;
  /// How the band was sampled, e.g. "200 log grid + 12 poles + 50 refinement".
  std::string sampling() const;
};

/// Evaluates band errors of reduced models against a (cached) full model.
class ECMOR_API BandErrorEstimator {
 public:
  BandErrorEstimator(ResponseCache& full, Band band, BandErrorOptions options);
  /// Error of `reduced` over the band with the options' sampling.
  BandError evaluate(const ReducedModel& reduced);
  /// Error on exactly the given frequencies (no refinement, no pole samples).
  BandError evaluate_on(const ReducedModel& reduced, const std::vector<double>& f_hz);
  /// Re-check on an independent grid: `factor` times denser than the options' grid, offset so that
  /// no frequency coincides with it, plus refinement of its own local maxima; the largest errors
  /// are re-evaluated with a dense LU of P_r(s), independently of the fast Hessenberg path.
  BandError verify(const ReducedModel& reduced, Index factor = 4);

  const Band& band() const { return m_band; }
  const BandErrorOptions& options() const { return m_options; }
  const std::vector<double>& grid() const { return m_grid; }

 private:
  BandError assemble(const ReducedModel& reduced, std::vector<double> f_hz, Index grid,
                     Index poles, bool refine, bool dense_peaks);
  ResponseCache& m_full;
  Band m_band;
  BandErrorOptions m_options;
  std::vector<double> m_grid;
  // Largest ||H||_2 and ||H||_F on the fixed grid: the scale of "H vanishes". Taken from the grid
  // only, so that a sample next to a lightly damped resonance cannot inflate it.
  double m_scale2 = 0.0;
  double m_scaleF = 0.0;
};

}  // namespace ecmor
