// eigen_instances_lu_qr.cpp: the definitions of one part of the Eigen instantiations that
// eigen_instances.hpp declares (see there why); compiled once, linked into every in-tree target.
#include "base/eigen_instances.hpp"

#undef ECMOR_EIGEN_EXTERN
#define ECMOR_EIGEN_EXTERN

ECMOR_EIGEN_INSTANCES_LU_QR
