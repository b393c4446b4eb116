// model.cpp: implementation pending (foundation issue in progress).
#include "ecmor/model.hpp"
