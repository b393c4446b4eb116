// history.cpp: implementation pending (foundation issue in progress).
#include "ecmor/history.hpp"
