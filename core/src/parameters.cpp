// parameters.cpp: implementation pending (foundation issue in progress).
#include "ecmor/parameters.hpp"
