// matrix_market.cpp: implementation pending (foundation issue in progress).
#include "ecmor/matrix_market.hpp"
