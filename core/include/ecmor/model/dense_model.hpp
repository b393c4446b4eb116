#pragma once
/// \file dense_model.hpp
/// Dense forms of a model: a full (sparse) model as dense matrices, and the first-order
/// realisation of a reduced model. For the dense Gramians, H2 and H-infinity norms of small models.

#include "ecmor/export.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor {

/// Largest dense state dimension densify() accepts (N for descriptor models, 2N for second-order
/// ones): a dense Schur form of 6000 x 6000 already takes minutes and 0.6 GB.
constexpr Index kMaxDenseStates = 6000;

/// The first-order realisation E x' = A x + B u, y = C x of a reduced model: a descriptor model
/// is returned as it is; a second-order one in x = [q; q'] as
///     E = diag(I, M),  A = [[0, I], [-K, -D]],  B = [0; B],  C = [C, Cv]  (Cv = 0 when empty).
ECMOR_API ReducedDescriptorModel first_order_realization(const ReducedModel& model);

/// A full (sparse) model as a dense model of the same kind, for dense H2 norms and Gramians of
/// small full models.
/// \throws InputError when the state dimension (N, or 2N for second order) exceeds
///         kMaxDenseStates.
ECMOR_API ReducedModel densify(const Model& model);

}  // namespace ecmor
