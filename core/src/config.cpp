// config.cpp: implementation pending (foundation issue in progress).
#include "ecmor/config.hpp"
