#pragma once
// compression.hpp: after a run has accepted a model, the smallest model inside it that still meets
// the target (issue 51). The accepted model is small and dense, so the search happens at the
// reduced level: no full-model work but the re-check of the model finally kept.
#include <optional>
#include <string>

#include "ecmor/linalg/rigid_body.hpp"
#include "ecmor/measures/band_error.hpp"
#include "ecmor/plugin/reducer.hpp"
#include "ecmor/response/frequency_response.hpp"
#include "ecmor/strategies/driver.hpp"

namespace ecmor::driver {

/// Reduced modal truncation of an accepted Galerkin model (W = V) with symmetric reduced matrices:
/// second order (Mr positive definite; modes Kr phi = lambda Mr phi) or first order (Er positive
/// definite; modes -Ar phi = lambda Er phi). The modes are ranked by their largest contribution to
/// the response over the band relative to the response there, and the smallest leading set whose
/// band error meets the tolerance, without and with the static correction of the modes left out,
/// is found by bisection on the estimator's grid (and, in estimate mode, the frequencies where the
/// full model was solved: no new full solves). The smaller candidate is then re-checked as any
/// accepted model (estimator.verify and its stability), and the search steps back towards the
/// accepted order when the re-check fails (at most three re-checks). The modes at the full
/// model's rigid-body eigenvalue (rigid.count of the lowest, second order) are always kept. The
/// compressed model is the Galerkin projection onto V S (S: the kept modes and the correction
/// columns): V, W and the reduced matrices stay consistent (W' M V = S' Mr S), in the accepted
/// model's form, symmetric and definite. `report.factorizations` counts the full-model responses
/// computed meanwhile (one factorisation each). Returns the compressed model with its re-check in
/// `verified`, or std::nullopt (the accepted model stays; report.note says why).
std::optional<ReducerResult> compress_accepted(const ReducerResult& accepted,
                                               BandErrorEstimator& estimator,
                                               const ResponseCache& cache, double tolerance,
                                               Index verify_factor, const RigidBodyModes& rigid,
                                               CompressionReport& report, BandError& verified);

}  // namespace ecmor::driver
