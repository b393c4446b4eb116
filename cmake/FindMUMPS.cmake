# FindMUMPS: the sequential MUMPS of Debian's libmumps-seq-dev, complex double arithmetic (zmumps)
# with its stub MPI. Defines MUMPS::zmumps_seq. Used for complex symmetric LDL^T factorisations
# (core/src/mumps_ldlt.cpp); the PETSc backend brings its own (parallel) MUMPS in its module.
include(FindPackageHandleStandardArgs)
find_path(MUMPS_INCLUDE_DIR NAMES zmumps_c.h)
find_library(MUMPS_ZMUMPS_LIBRARY NAMES zmumps_seq)
find_library(MUMPS_COMMON_LIBRARY NAMES mumps_common_seq)
find_library(MUMPS_MPISEQ_LIBRARY NAMES mpiseq_seq)
find_package_handle_standard_args(MUMPS
  REQUIRED_VARS MUMPS_ZMUMPS_LIBRARY MUMPS_COMMON_LIBRARY MUMPS_MPISEQ_LIBRARY MUMPS_INCLUDE_DIR)
if(MUMPS_FOUND AND NOT TARGET MUMPS::zmumps_seq)
  add_library(MUMPS::zmumps_seq UNKNOWN IMPORTED)
  set_target_properties(MUMPS::zmumps_seq PROPERTIES
    IMPORTED_LOCATION "${MUMPS_ZMUMPS_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${MUMPS_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${MUMPS_COMMON_LIBRARY};${MUMPS_MPISEQ_LIBRARY}")
endif()
mark_as_advanced(MUMPS_INCLUDE_DIR MUMPS_ZMUMPS_LIBRARY MUMPS_COMMON_LIBRARY MUMPS_MPISEQ_LIBRARY)
