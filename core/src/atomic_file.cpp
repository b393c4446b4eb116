// atomic_file.cpp: implementation pending (foundation issue in progress).
#include "ecmor/atomic_file.hpp"
