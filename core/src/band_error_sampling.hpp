#pragma once
// band_error_sampling.hpp: what the dense and the estimate mode of BandErrorEstimator share
// (private to core): the comparison of a reduced model with a reference response on a set of
// frequencies, the refinement of its local maxima, and the assembly of a BandError.
#include <functional>
#include <vector>

#include "ecmor/band_error.hpp"

namespace ecmor::detail {

/// The reference side of the comparison at each requested frequency: the full model's own H
/// (exact = 1) or an estimate of it (exact = 0).
struct ReferenceValues {
  std::vector<ComplexMatrix> H;
  std::vector<char> exact;
};
using ReferenceSource = std::function<ReferenceValues(const std::vector<double>& f_hz)>;

struct SamplingPlan {
  Index grid = 0;            ///< how many of the frequencies form the grid (for sampling())
  Index poles = 0;           ///< how many are pole samples
  bool refine = false;       ///< golden-section refinement of the largest local maxima
  bool dense_peaks = false;  ///< re-evaluate the ten largest errors with a dense LU of P_r(s)
};

/// Compares `reduced` with `source` at f_hz (sorted and made unique here), refines as planned and
/// assembles the BandError (sup over all samples; the estimate fields are left to the caller).
/// scale2 / scaleF: the largest ||H||_2 / ||H||_F of the band, the scale of "H vanishes".
BandError assemble_band_error(const ReducedModel& reduced, std::vector<double> f_hz,
                              const ReferenceSource& source, const SamplingPlan& plan,
                              const BandErrorOptions& options, const Band& band, double scale2,
                              double scaleF, int threads);

/// Frequencies Im(p) / 2 pi in the band of the poles p with damping ratio >= 1e-8, least damped
/// first, at most `max` of them, with their damping ratios.
std::vector<std::pair<double, double>> pole_frequencies(const ComplexVector& p, const Band& band,
                                                        Index max);

/// Number of poles with Re >= 0 (or NaN).
Index unstable_count(const ComplexVector& p);

}  // namespace ecmor::detail
