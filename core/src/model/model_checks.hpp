#pragma once
// model_checks.hpp: input checks shared by the core's norm computations. Private to the core's
// sources.
#include <string>
#include <string_view>

#include "ecmor/base/error.hpp"
#include "ecmor/model/model.hpp"

namespace ecmor::detail {

/// Refuses two models whose transfer matrices differ in size, naming both sizes.
/// \throws InputError "<origin>: the models have p x m and p' x m' transfer matrices ...".
inline void require_same_io(const ReducedModel& a, const ReducedModel& b, std::string_view origin) {
  if (inputs_of(a) != inputs_of(b) || outputs_of(a) != outputs_of(b))
    throw InputError(std::string(origin) + ": the models have " + std::to_string(outputs_of(a)) +
                     " x " + std::to_string(inputs_of(a)) + " and " +
                     std::to_string(outputs_of(b)) + " x " + std::to_string(inputs_of(b)) +
                     " transfer matrices (outputs x inputs): they must be equal");
}

}  // namespace ecmor::detail
