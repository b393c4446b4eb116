#pragma once
/// \file commands.hpp
/// The subcommands of the `ecmor` command line. Each returns the process exit code.

#include <filesystem>
#include <string>
#include <vector>

namespace ecmor::app {

struct CommonOptions {
  std::vector<std::filesystem::path> plugin_paths;  ///< --plugin (files or directories)
  bool no_default_plugins = false;                  ///< --no-default-plugins
  bool quiet = false;                               ///< --quiet
  std::filesystem::path output_dir;                 ///< --output: overrides output.dir
};

/// `ecmor reduce CONFIG`: 0 target met, 2 usable model but target missed, 1 error, 130 interrupted.
int reduce(const std::filesystem::path& config, const CommonOptions& common);
/// `ecmor plugins`: list the registered reducers with library, version and parameters.
int plugins(const CommonOptions& common);
/// `ecmor info MODEL_DIR`: sizes, nnz, symmetry, definiteness, lowest eigenfrequencies.
int info(const std::filesystem::path& model_dir, int eigenfrequencies, const CommonOptions& common);

}  // namespace ecmor::app
