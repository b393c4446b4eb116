# FindSuiteSparse: SuiteSparse 5.x ships no CMake config; locate CHOLMOD and UMFPACK and the
# libraries they need. Defines SuiteSparse::CHOLMOD and SuiteSparse::UMFPACK.
include(FindPackageHandleStandardArgs)
find_path(SuiteSparse_INCLUDE_DIR NAMES SuiteSparse_config.h PATH_SUFFIXES suitesparse)
find_library(SuiteSparse_config_LIBRARY NAMES suitesparseconfig)
foreach(lib AMD CAMD COLAMD CCOLAMD CHOLMOD UMFPACK)
  string(TOLOWER ${lib} lower)
  find_library(SuiteSparse_${lib}_LIBRARY NAMES ${lower})
endforeach()
if(SuiteSparse_INCLUDE_DIR AND EXISTS "${SuiteSparse_INCLUDE_DIR}/SuiteSparse_config.h")
  file(STRINGS "${SuiteSparse_INCLUDE_DIR}/SuiteSparse_config.h" _ss_ver REGEX "#define SUITESPARSE_(MAIN|SUB)_VERSION")
  string(REGEX REPLACE ".*MAIN_VERSION +([0-9]+).*" "\\1" _ss_major "${_ss_ver}")
  string(REGEX REPLACE ".*SUB_VERSION +([0-9]+).*" "\\1" _ss_minor "${_ss_ver}")
  set(SuiteSparse_VERSION "${_ss_major}.${_ss_minor}")
endif()
set(SuiteSparse_CHOLMOD_FOUND FALSE)
set(SuiteSparse_UMFPACK_FOUND FALSE)
if(SuiteSparse_CHOLMOD_LIBRARY)
  set(SuiteSparse_CHOLMOD_FOUND TRUE)
endif()
if(SuiteSparse_UMFPACK_LIBRARY)
  set(SuiteSparse_UMFPACK_FOUND TRUE)
endif()
find_package_handle_standard_args(SuiteSparse
  REQUIRED_VARS SuiteSparse_INCLUDE_DIR SuiteSparse_config_LIBRARY SuiteSparse_AMD_LIBRARY
  VERSION_VAR SuiteSparse_VERSION HANDLE_COMPONENTS)
if(SuiteSparse_FOUND AND NOT TARGET SuiteSparse::config)
  add_library(SuiteSparse::config UNKNOWN IMPORTED)
  set_target_properties(SuiteSparse::config PROPERTIES IMPORTED_LOCATION "${SuiteSparse_config_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${SuiteSparse_INCLUDE_DIR}")
  foreach(lib AMD CAMD COLAMD CCOLAMD)
    add_library(SuiteSparse::${lib} UNKNOWN IMPORTED)
    set_target_properties(SuiteSparse::${lib} PROPERTIES IMPORTED_LOCATION "${SuiteSparse_${lib}_LIBRARY}"
      INTERFACE_LINK_LIBRARIES SuiteSparse::config)
  endforeach()
  add_library(SuiteSparse::CHOLMOD UNKNOWN IMPORTED)
  set_target_properties(SuiteSparse::CHOLMOD PROPERTIES IMPORTED_LOCATION "${SuiteSparse_CHOLMOD_LIBRARY}"
    INTERFACE_LINK_LIBRARIES "SuiteSparse::AMD;SuiteSparse::CAMD;SuiteSparse::COLAMD;SuiteSparse::CCOLAMD")
  add_library(SuiteSparse::UMFPACK UNKNOWN IMPORTED)
  set_target_properties(SuiteSparse::UMFPACK PROPERTIES IMPORTED_LOCATION "${SuiteSparse_UMFPACK_LIBRARY}"
    INTERFACE_LINK_LIBRARIES "SuiteSparse::CHOLMOD;SuiteSparse::AMD")
endif()
mark_as_advanced(SuiteSparse_INCLUDE_DIR SuiteSparse_config_LIBRARY)
