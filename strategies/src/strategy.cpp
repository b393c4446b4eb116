#include "ecmor/strategies/strategy.hpp"
