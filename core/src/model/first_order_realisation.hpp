#pragma once
// first_order_realisation.hpp: a reduced model as x' = F x + G u, y = L x (private to core; used
// by ReducedResponse and by the time-span suggestion of time_domain.hpp).
#include <optional>

#include "ecmor/base/types.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor::detail {

struct FirstOrderRealisation {
  Matrix F, G, L;
};

/// Second order: x = [q; q'], F = [[0, I], [-Mr^-1 Kr, -Mr^-1 Dr]], G = [0; Mr^-1 Br],
/// L = [Cr, Cvr]; descriptor: F = Er^-1 Ar, G = Er^-1 Br, L = Cr. Nothing when Mr (Er) is empty,
/// its reciprocal condition (LU estimate) is at most min_rcond, or the result is not finite:
/// forming Mr^-1 [Kr Dr] loses about log10(1 / rcond) digits. The shapes are the caller's to check.
std::optional<FirstOrderRealisation> first_order_realisation(const ReducedModel& model,
                                                             double min_rcond);

}  // namespace ecmor::detail
