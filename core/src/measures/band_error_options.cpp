// band_error_options.cpp: the band error's names (norms, verification modes) and options, stated
// once: the YAML reader (sections `target` and `error`), the Python module and
// BandErrorOptions::validate() all apply these (see ecmor/measures/band_error.hpp).
#include <string>

#include "ecmor/base/options.hpp"
#include "ecmor/measures/band_error.hpp"

namespace ecmor {

const NameList<ErrorNorm>& error_norm_names() {
  static const NameList<ErrorNorm> names = {{"spectral", ErrorNorm::Spectral},
                                            {"frobenius", ErrorNorm::Frobenius}};
  return names;
}

std::string to_string(ErrorNorm norm) { return name_of(error_norm_names(), norm); }

ErrorNorm parse_error_norm(const std::string& name) {
  return value_of(error_norm_names(), name, "norm");
}

const NameList<ErrorVerify>& error_verify_names() {
  static const NameList<ErrorVerify> names = {{"dense", ErrorVerify::Dense},
                                              {"estimate", ErrorVerify::Estimate},
                                              {"auto", ErrorVerify::Auto}};
  return names;
}

std::string to_string(ErrorVerify verify) { return name_of(error_verify_names(), verify); }

ErrorVerify parse_error_verify(const std::string& name) {
  return value_of(error_verify_names(), name, "verify");
}

const OptionSpecs<BandErrorOptions>& BandErrorOptions::specs() {
  using E = BandErrorOptions;
  static const OptionSpecs<E> specs({
      option("grid_points", &E::grid_points, "initial log-spaced frequencies over the band")
          .range(Range::closed(2, 1e6)),
      option("pole_samples", &E::pole_samples,
             "also sample at Im(p)/2π of the reduced poles inside the band (resonances)"),
      option("max_pole_samples", &E::max_pole_samples,
             "at most this many pole samples, least damped first")
          .range(Range::at_least(0)),
      option("refine_peaks", &E::refine_peaks, "local maxima of the error refined per evaluation")
          .range(Range::at_least(0)),
      option("refine_evaluations", &E::refine_evaluations,
             "golden-section steps per refined peak at most; a peak stops earlier when its "
             "value has not risen (by 1e-4 relative) for 6 steps or its bracket is below 1e-9 "
             "relative in f")
          .range(Range::closed(0, 200)),
      option("zero_threshold", &E::zero_threshold,
             "`‖H(f)‖ <= zero_threshold · max_f ‖H‖` counts as \"H vanishes\": relative error "
             "undefined there, excluded and reported")
          .range(Range::closed_open(0, 1)),
      choice("verify", &E::verify, error_verify_names(),
             "how the full model's H is obtained: `dense` = a full-model solve (sparse "
             "factorisation) at every sample; `estimate` = a reference model grown from the "
             "run's full solves stands in for H, and full solves are made only where the "
             "estimate peaks, at random and at the band edges; `auto` = `dense` up to "
             "`dense_max_states`, else `estimate` until its reference model has cost more than "
             "the dense sampling would (counted in flops, so every run decides alike), then "
             "`dense` ([error-measures.md](error-measures.md#the-estimator-error-control-"
             "without-a-full-solve-per-frequency-errorverify))"),
      option("dense_max_states", &E::dense_max_states,
             "`auto` chooses `dense` for full models with at most this many states N")
          .range(Range::at_least(0)),
      option("estimate_points", &E::estimate_points,
             "estimate mode: log-spaced samples of the estimate (no full solve each)")
          .range(Range::closed(2, 1e6)),
      option("reference_points", &E::reference_points,
             "estimate mode: full solves that seed the reference model: the band edges and "
             "golden-ratio points in log f between them")
          .range(Range::closed(2, 10000)),
      option("check_peaks", &E::check_peaks,
             "estimate mode: largest local maxima of the estimate solved per round of the "
             "re-check")
          .range(Range::at_least(1)),
      option("random_checks", &E::random_checks,
             "estimate mode: log-uniform random frequencies solved per re-check (fixed seed: "
             "runs are reproducible)")
          .range(Range::at_least(0)),
      option("check_rounds", &E::check_rounds,
             "estimate mode: rounds of (estimate, solve its peaks) per re-check; rounds after "
             "the first solve only maxima above the largest error already measured")
          .range(Range::at_least(1)),
      option("probe_solves", &E::probe_solves,
             "estimate mode: full solves per evaluation at the estimate's peak when it has none "
             "there (the estimate is then exact where it is largest)")
          .range(Range::at_least(0)),
  });
  return specs;
}

void BandErrorOptions::validate() const { specs().validate(*this, "BandErrorOptions"); }

}  // namespace ecmor
