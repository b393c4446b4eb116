// eigensolver.cpp: implementation pending (foundation issue in progress).
#include "ecmor/eigensolver.hpp"
