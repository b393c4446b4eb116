#pragma once
/// \file error.hpp
/// The exception hierarchy of ecmor. Everything a user can cause (bad files, bad configuration,
/// plugins that fail to load) or a numerical breakdown throws a subclass of ecmor::Error, defined
/// here in core so that the application can catch a plugin's throw by type. Missing a tolerance is
/// never an exception: it is a result with a termination reason.

#include <stdexcept>
#include <string>

#include "ecmor/export.hpp"

namespace ecmor {

/// Root of all ecmor errors. what() is a complete, user-facing message.
class ECMOR_API Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message);
  ~Error() override;
};

/// Malformed or inconsistent input data (Matrix Market files, model matrices): the message names
/// the file (and line) or the matrix, and the rule broken.
class ECMOR_API InputError : public Error {
 public:
  using Error::Error;
  ~InputError() override;
};

/// Invalid configuration (YAML keys, types, ranges, options structs): names the key and its line.
class ECMOR_API ConfigError : public Error {
 public:
  using Error::Error;
  ~ConfigError() override;
};

/// A plugin could not be loaded or registered: names the path and the cause.
class ECMOR_API PluginError : public Error {
 public:
  using Error::Error;
  ~PluginError() override;
};

/// Numerical breakdown (singular shifted matrix, failed factorisation, eigensolver failure, NaN in
/// a basis): names the operation, the shift or iteration where known.
class ECMOR_API NumericalError : public Error {
 public:
  using Error::Error;
  ~NumericalError() override;
};

/// The machine cannot hold what the run needs (memory predicted beyond what the process may take):
/// names the need, the limit and the options that would fit.
class ECMOR_API ResourceError : public Error {
 public:
  using Error::Error;
  ~ResourceError() override;
};

/// File system and output failures (cannot create, write or rename a file): names the path.
class ECMOR_API IoError : public Error {
 public:
  using Error::Error;
  ~IoError() override;
};

}  // namespace ecmor
