# FindMatio: matio (Debian libmatio-dev 1.5.23) ships a pkg-config file and no CMake package.
# Defines Matio::Matio. pkg-config also brings HDF5 (MAT v7.3) and zlib for a static link; without
# pkg-config the library and header are searched directly (the shared libmatio pulls those in).
include(FindPackageHandleStandardArgs)
find_package(PkgConfig QUIET)
if(PkgConfig_FOUND)
  pkg_check_modules(PC_MATIO QUIET IMPORTED_TARGET matio)
endif()
if(PC_MATIO_FOUND)
  set(Matio_VERSION ${PC_MATIO_VERSION})
  find_package_handle_standard_args(Matio REQUIRED_VARS PC_MATIO_LINK_LIBRARIES
    VERSION_VAR Matio_VERSION)
  if(Matio_FOUND AND NOT TARGET Matio::Matio)
    add_library(Matio::Matio INTERFACE IMPORTED)
    target_link_libraries(Matio::Matio INTERFACE PkgConfig::PC_MATIO)
  endif()
else()
  find_path(Matio_INCLUDE_DIR matio.h)
  find_library(Matio_LIBRARY matio)
  if(Matio_INCLUDE_DIR AND EXISTS "${Matio_INCLUDE_DIR}/matio_pubconf.h")
    file(STRINGS "${Matio_INCLUDE_DIR}/matio_pubconf.h" _matio_version
         REGEX "define MATIO_VERSION_STR ")
    string(REGEX REPLACE ".*\"(.*)\".*" "\\1" Matio_VERSION "${_matio_version}")
  endif()
  find_package_handle_standard_args(Matio REQUIRED_VARS Matio_LIBRARY Matio_INCLUDE_DIR
    VERSION_VAR Matio_VERSION)
  if(Matio_FOUND AND NOT TARGET Matio::Matio)
    add_library(Matio::Matio UNKNOWN IMPORTED)
    set_target_properties(Matio::Matio PROPERTIES IMPORTED_LOCATION "${Matio_LIBRARY}"
      INTERFACE_INCLUDE_DIRECTORIES "${Matio_INCLUDE_DIR}")
  endif()
endif()
