#pragma once
// band_error_sampling.hpp: what the dense and the estimate mode of BandErrorEstimator share
// (private to core): the comparison of a reduced model with a reference response on a set of
// frequencies, the refinement of its local maxima, and the assembly of a BandError.
#include <functional>
#include <map>
#include <optional>
#include <vector>

#include "ecmor/measures/band_error.hpp"
#include "ecmor/response/reduced_response.hpp"

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

/// A candidate reduced model as the band error samples it: its response (the Hessenberg form,
/// built once), its values at the frequencies already sampled, and its poles, all kept for the
/// duration of one evaluation. The estimate mode samples one candidate in several rounds (a probe
/// solve, the re-check's rounds) at mostly the same frequencies; measured on
/// triplechain_saak09_n451_krylov (order 241), rebuilding all three per round was about half of
/// the run. The values are the same ones recomputed, bit for bit.
class CandidateResponse {
 public:
  explicit CandidateResponse(const ReducedModel& model) : m_model(model), m_response(model) {}
  const ReducedModel& model() const { return m_model; }
  const ReducedResponse& response() const { return m_response; }
  /// Hr(i 2 pi f) where it was computed before (nullopt inside: f was a pole of the reduced
  /// model), or nullptr when it was not.
  const std::optional<ComplexMatrix>* find(double f_hz) const {
    const auto it = m_values.find(f_hz);
    return it == m_values.end() ? nullptr : &it->second;
  }
  void keep(double f_hz, std::optional<ComplexMatrix> value) {
    m_values.emplace(f_hz, std::move(value));
  }
  /// The poles (computed once). \throws NumericalError when the eigenvalues fail, each time.
  const ComplexVector& poles();

 private:
  const ReducedModel& m_model;
  ReducedResponse m_response;
  std::map<double, std::optional<ComplexMatrix>> m_values;
  std::optional<ComplexVector> m_poles;
};

/// What a candidate is compared with, and how: the reference side, the estimator's options and
/// band, the scale of "H vanishes" and the threads of the sampling.
struct Comparison {
  ReferenceSource source;
  const BandErrorOptions& options;
  const Band& band;
  double scale2 = 0.0;  ///< the largest ||H||_2 of the band (zero_threshold is relative to it)
  double scaleF = 0.0;  ///< the largest ||H||_F of the band
  int threads = 0;      ///< of the sampling (<= 0: OpenMP's default)
};

/// Compares `candidate` with `with.source` at f_hz (sorted and made unique here), refines the
/// largest local maxima and re-checks the largest errors by a dense LU as `plan` says, and
/// assembles the BandError (sup over all samples; the estimate fields are left to the caller).
BandError assemble_band_error(CandidateResponse& candidate, std::vector<double> f_hz,
                              const SamplingPlan& plan, const Comparison& with);

/// Frequencies Im(p) / 2 pi in the band of the poles p with damping ratio >= 1e-8, least damped
/// first, at most `max` of them, with their damping ratios.
std::vector<std::pair<double, double>> pole_frequencies(const ComplexVector& p, const Band& band,
                                                        Index max);

/// Number of poles with Re >= 0 (or NaN).
Index unstable_count(const ComplexVector& p);

}  // namespace ecmor::detail
