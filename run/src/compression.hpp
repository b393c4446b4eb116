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
#include "ecmor/run/summary.hpp"

namespace ecmor::run {

/// The smallest model inside an accepted one (docs/strategies.md, "Compression after
/// acceptance"). Families nested by a count: for a Galerkin model (W = V) with symmetric reduced
/// matrices, its modes ranked by their band contribution, without and with the static correction of
/// the rest (second order: Kr phi = lambda Mr phi; first order: -Ar phi = lambda Er phi; the lowest
/// rigid.count modes always kept); for any other model without rigid-body modes, the leading
/// directions of its band responses (one-sided for a Galerkin model, two-sided for a
/// Petrov-Galerkin one; the position parts for second order). The smallest stable count meeting
/// the tolerance on the estimator's grid and the accepted model's resonances is found by bisection
/// (no full solve); it is re-checked by BandErrorEstimator::verify_near against the accepted model
/// (`report.error_before`: its verified error), at most five new full solves per compression, and
/// on failure the count steps up (four re-checks at most). The compressed model is the projection
/// onto V S_V and W S_W, in the accepted model's form: V, W and the reduced matrices stay
/// consistent. `report.factorizations` counts the full-model responses computed meanwhile (one
/// factorisation each). Returns the compressed model with its re-check in `verified`, or
/// std::nullopt (the accepted model stays; report.note says why).
std::optional<ReducerResult> compress_accepted(const ReducerResult& accepted,
                                               BandErrorEstimator& estimator,
                                               const ResponseCache& cache, double tolerance,
                                               Index verify_factor, const RigidBodyModes& rigid,
                                               CompressionReport& report, BandError& verified);

}  // namespace ecmor::run
