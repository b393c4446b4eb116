#pragma once
// reducer_guard.hpp (private): the checks at the plugin boundary. Every reducer the registry
// creates is wrapped, so that a plugin that throws something other than an ecmor::Error, returns
// bases of the wrong shape or non-finite numbers, or is called out of order is stopped where it
// happens, with the reducer's name and library, instead of corrupting a strategy's state later.
#include <filesystem>
#include <memory>
#include <string>

#include "ecmor/plugin/reducer.hpp"

namespace ecmor::detail {

/// Wraps `inner` (created by the factory of reducer `info.name` from `library`; empty: added
/// directly). Requests with a modal block go only to reducers whose info says they take one.
std::unique_ptr<Reducer> guard_reducer(std::unique_ptr<Reducer> inner, const ReducerInfo& info,
                                       const std::filesystem::path& library);

}  // namespace ecmor::detail
