// registry.cpp: implementation pending (foundation issue in progress).
#include "ecmor/registry.hpp"
