#include "ecmor/base/error.hpp"

namespace ecmor {

// Out-of-line destructors anchor the vtables and type_info in libecmor_core, so that an exception
// thrown in a plugin is caught by type in the application.
Error::Error(const std::string& message) : std::runtime_error(message) {}
Error::~Error() = default;
InputError::~InputError() = default;
ConfigError::~ConfigError() = default;
PluginError::~PluginError() = default;
NumericalError::~NumericalError() = default;
ResourceError::~ResourceError() = default;
IoError::~IoError() = default;

}  // namespace ecmor
