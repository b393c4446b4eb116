// projection.cpp: implementation pending (foundation issue in progress).
#include "ecmor/projection.hpp"
