# FindIpopt: Ipopt 3.11 (Debian coinor-libipopt-dev) ships only a pkg-config file. Defines Ipopt::Ipopt.
include(FindPackageHandleStandardArgs)
find_package(PkgConfig REQUIRED)
pkg_check_modules(PC_IPOPT QUIET IMPORTED_TARGET ipopt)
find_package_handle_standard_args(Ipopt REQUIRED_VARS PC_IPOPT_FOUND VERSION_VAR PC_IPOPT_VERSION)
if(Ipopt_FOUND AND NOT TARGET Ipopt::Ipopt)
  add_library(Ipopt::Ipopt INTERFACE IMPORTED)
  target_link_libraries(Ipopt::Ipopt INTERFACE PkgConfig::PC_IPOPT)
endif()
