// shifted_solver.cpp: implementation pending (foundation issue in progress).
#include "ecmor/shifted_solver.hpp"
