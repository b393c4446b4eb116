// frequency_response.cpp: implementation pending (foundation issue in progress).
#include "ecmor/frequency_response.hpp"
