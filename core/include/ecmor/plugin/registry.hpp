#pragma once
/// \file registry.hpp
/// The registry of reducers and the Boost.DLL plugin loader. Built-in and external plugins go
/// through the same path: a shared library exporting the ECMOR_PLUGIN entry points (plugin.hpp).
/// A reducer created from a plugin keeps its library loaded for as long as the reducer lives.

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "ecmor/export.hpp"
#include "ecmor/plugin/reducer.hpp"

namespace ecmor {

class ECMOR_API Registry {
 public:
  Registry();
  ~Registry();
  Registry(const Registry&) = delete;
  Registry& operator=(const Registry&) = delete;

  /// Registers a factory. During load_plugin() the factory is attributed to that library.
  /// \throws PluginError if the name is empty, not snake_case, or already registered (naming
  ///         both libraries).
  void add(ReducerFactory factory);

  /// Loads one plugin: checks that the file exists and is a loadable shared library, that it
  /// exports the ecmor entry points, that its ABI version equals ECMOR_PLUGIN_ABI_VERSION, then
  /// calls its registration function. Loading the same file twice is a no-op.
  /// \throws PluginError naming the path and the cause (missing file, not a shared library (with
  ///         the loader's message), not an ecmor plugin, ABI mismatch (both versions and ecmor
  ///         versions), registration threw (with its message)). Nothing is registered on failure.
  void load_plugin(const std::filesystem::path& path);

  /// Loads every `*.so` in `dir` (not recursive), in name order. Errors are collected, not thrown:
  /// returns one message per library that failed. A missing directory is not an error.
  std::vector<std::string> load_directory(const std::filesystem::path& dir);

  struct Entry {
    ReducerInfo info;
    std::filesystem::path library;  ///< empty for reducers added directly (tests)
  };
  std::vector<Entry> entries() const;
  std::vector<std::string> names() const;
  bool contains(const std::string& name) const;

  /// Creates a reducer by name, passing `params`, then checks that every key was used.
  /// \throws ConfigError for an unknown name (listing the registered ones, suggesting the
  ///         nearest) or unknown/invalid parameters.
  std::shared_ptr<Reducer> create(const std::string& name, const ParameterMap& params) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> m_impl;
};

/// Plugin directories searched by default, in order: each entry of $ECMOR_PLUGIN_PATH
/// (colon-separated), then <dir of the running executable>/../lib/ecmor/plugins.
ECMOR_API std::vector<std::filesystem::path> default_plugin_directories();

}  // namespace ecmor
