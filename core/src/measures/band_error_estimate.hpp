#pragma once
// band_error_estimate.hpp: the estimate mode of BandErrorEstimator (private to core). See
// band_error.hpp and docs/error-measures.md#the-estimator.
#include <map>
#include <memory>
#include <random>
#include <vector>

#include "ecmor/measures/band_error.hpp"
#include "ecmor/response/reduced_response.hpp"
#include "ecmor/response/reference_model.hpp"
#include "measures/band_error_sampling.hpp"

namespace ecmor::detail {

class EstimateEngine {
 public:
  /// Seeds the reference model with options.reference_points full solves (band edges included).
  EstimateEngine(ResponseCache& full, const Band& band, const BandErrorOptions& options);

  /// The estimated error curve; where the estimate peaks without a full solve, up to
  /// options.probe_solves full solves there (the estimate is then exact where it is largest).
  BandError evaluate(const ReducedModel& reduced);
  /// Errors at exactly these frequencies (exact where the full model was solved, else estimated).
  BandError evaluate_on(const ReducedModel& reduced, const std::vector<double>& f_hz);
  /// The re-check: full solves at the estimate's largest local maxima (in rounds), a random set
  /// and the band edges. sup_relative is the largest error against the full model's own H;
  /// estimate_sup the largest estimate elsewhere.
  BandError verify(const ReducedModel& reduced);
  /// The re-check of BandErrorEstimator::verify_near: full solves at exactly `solve` (those not
  /// yet solved), then the estimate over the band with refinement; sup_relative as for verify().
  BandError verify_at(const ReducedModel& reduced, const std::vector<double>& solve);
  void offer_basis(const Matrix& basis);
  /// Full solves per evaluation at the estimate's peak (BandErrorOptions::probe_solves).
  Index probe_solves() const { return m_options.probe_solves; }
  void set_probe_solves(Index probes) { m_options.probe_solves = probes; }
  const ReferenceModel& reference() const { return m_reference; }
  /// Floating-point operations spent on the reference model itself (its reduced forms, poles and
  /// values), modelled from its order: the work the dense mode does not do. Full solves are not
  /// included.
  double overhead_flops() const { return m_overhead_flops; }
  /// Wall time spent building and evaluating the reference model (its basis, projections,
  /// Hessenberg form, poles and values): the work the dense mode does not do. Full solves are not
  /// included.
  double reference_seconds() const { return m_reference_seconds; }

 private:
  ReferenceValues values(const std::vector<double>& f_hz);
  // Full solves at f_hz (those not yet solved), added to the cache and the reference model.
  Index solve_full(const std::vector<double>& f_hz);
  void refresh();
  // The reference's evaluation error at solved frequencies (Hessenberg or dense LU path).
  double floor_of(bool dense_lu) const;
  // Picks the more accurate evaluation of the reference model for its current version.
  void choose_evaluation();
  std::vector<double> sample_set(CandidateResponse& reduced, Index* pole_count, Index* unstable);
  BandError assemble(CandidateResponse& reduced, std::vector<double> f_hz, Index grid, Index poles,
                     bool refine, bool dense_peaks);
  // Fills the estimate fields of `e` (sup over exact samples, estimate_sup, effectivity).
  void finish(BandError& e, bool certify, const std::map<double, double>& estimate_before,
              Index new_solves) const;

  ResponseCache& m_full;
  Band m_band;
  BandErrorOptions m_options;
  ReferenceModel m_reference;
  std::vector<double> m_grid;
  // The reference model's response, per frequency, for its current version.
  Index m_version = -1;
  std::unique_ptr<ReducedResponse> m_response;
  std::map<double, ComplexMatrix> m_values;
  std::vector<double> m_pole_f;  // resonances of the reference model in the band
  Index m_pole_order = 0;        // reference order when they were computed
  bool m_dense_lu = false;       // evaluate the reference by dense LU (else Hessenberg)
  double m_floor = 0.0;          // its evaluation error at the solved frequencies
  std::mt19937_64 m_rng{20261126};
  double m_scale2 = 0.0, m_scaleF = 0.0;
  double m_overhead_flops = 0.0;
  double m_reference_seconds = 0.0;
  int m_reference_timing = 0;  // depth of the WallTimers on m_reference_seconds
};

}  // namespace ecmor::detail
