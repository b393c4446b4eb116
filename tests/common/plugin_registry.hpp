#pragma once
/// \file plugin_registry.hpp
/// The registry of one bundled plugin library for the plugin test suites, loaded once per test
/// binary from the build's plugin directory (ECMOR_TEST_PLUGIN_DIR, set by tests/CMakeLists.txt).

#include <filesystem>
#include <map>
#include <memory>
#include <string>

#include "ecmor/plugin/registry.hpp"

namespace ecmor::test {

/// The registry holding the reducers of `library` (e.g. "libecmor_krylov.so"). Loading failures
/// throw from the first call, with the loader's message naming the file.
inline Registry& plugin_registry(const std::string& library) {
  static std::map<std::string, std::unique_ptr<Registry>> registries;
  std::unique_ptr<Registry>& slot = registries[library];
  if (!slot) {
    auto fresh = std::make_unique<Registry>();
    fresh->load_plugin(std::filesystem::path(ECMOR_TEST_PLUGIN_DIR) / library);
    slot = std::move(fresh);
  }
  return *slot;
}

}  // namespace ecmor::test
