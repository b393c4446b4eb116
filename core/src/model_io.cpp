// model_io.cpp: implementation pending (foundation issue in progress).
#include "ecmor/model_io.hpp"
