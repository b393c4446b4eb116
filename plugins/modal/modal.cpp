#include "ecmor/plugin.hpp"
