// band_error.cpp: implementation pending (foundation issue in progress).
#include "ecmor/band_error.hpp"
