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

/// Reduced modal truncation of an accepted second-order Galerkin model (W = V; Mr, Dr, Kr
/// symmetric, Mr positive definite): the reduced pencil's modes Kr phi = lambda Mr phi are ranked
/// by their largest contribution to the response over the band, |c_i(w)| |b_i| /
/// |lambda_i - w^2 + i w d_i|, and the smallest leading set whose band error (on the frequencies
/// the full model was solved at, and in estimate mode the estimator's grid) meets the tolerance is
/// found by bisection; it is then re-checked as any accepted model (estimator.verify), and the
/// search steps back towards the accepted order when the re-check fails (at most three re-checks).
/// The modes at the full model's rigid-body eigenvalue (rigid.count of the lowest) are always
/// kept. The compressed model is the Galerkin projection onto V Phi_S: V, W and the reduced
/// matrices stay consistent (W' M V = Phi_S' Mr Phi_S), second order, symmetric and definite.
/// `report.factorizations` counts the full-model responses computed meanwhile (one factorisation
/// each). Returns the compressed model with its re-check in `verified`, or std::nullopt (the
/// accepted model stays; report.note says why).
std::optional<ReducerResult> compress_accepted(const ReducerResult& accepted,
                                               BandErrorEstimator& estimator,
                                               const ResponseCache& cache, double tolerance,
                                               Index verify_factor, const RigidBodyModes& rigid,
                                               CompressionReport& report, BandError& verified);

}  // namespace ecmor::driver
