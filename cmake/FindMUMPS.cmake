# FindMUMPS: the sequential MUMPS of Debian's libmumps-seq-dev, complex double arithmetic (zmumps)
# with its stub MPI. Defines MUMPS::zmumps_seq (headers only: core/src/linalg/mumps_ldlt.cpp opens the
# library at run time, see there) and MUMPS_ZMUMPS_SONAME, the name it is opened by.
include(FindPackageHandleStandardArgs)
find_path(MUMPS_INCLUDE_DIR NAMES zmumps_c.h)
find_library(MUMPS_ZMUMPS_LIBRARY NAMES zmumps_seq)
find_library(MUMPS_COMMON_LIBRARY NAMES mumps_common_seq)
find_library(MUMPS_MPISEQ_LIBRARY NAMES mpiseq_seq)
find_package_handle_standard_args(MUMPS
  REQUIRED_VARS MUMPS_ZMUMPS_LIBRARY MUMPS_COMMON_LIBRARY MUMPS_MPISEQ_LIBRARY MUMPS_INCLUDE_DIR)
if(MUMPS_FOUND AND NOT TARGET MUMPS::zmumps_seq)
  add_library(MUMPS::zmumps_seq INTERFACE IMPORTED)
  set_target_properties(MUMPS::zmumps_seq PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${MUMPS_INCLUDE_DIR}")
  # The soname (libzmumps_seq-5.5.so on Debian 12): what the run-time package installs.
  file(REAL_PATH "${MUMPS_ZMUMPS_LIBRARY}" _mumps_real)
  execute_process(COMMAND objdump -p "${_mumps_real}" OUTPUT_VARIABLE _mumps_dyn ERROR_QUIET)
  string(REGEX MATCH "SONAME +([^\n ]+)" _mumps_match "${_mumps_dyn}")
  if(CMAKE_MATCH_1)
    set(MUMPS_ZMUMPS_SONAME "${CMAKE_MATCH_1}")
  else()
    get_filename_component(MUMPS_ZMUMPS_SONAME "${_mumps_real}" NAME)
  endif()
endif()
mark_as_advanced(MUMPS_INCLUDE_DIR MUMPS_ZMUMPS_LIBRARY MUMPS_COMMON_LIBRARY MUMPS_MPISEQ_LIBRARY)
