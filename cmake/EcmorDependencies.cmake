# Every external dependency is found here, once, with the versions Debian 12 ships.
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(SuiteSparse 5.12 REQUIRED COMPONENTS CHOLMOD UMFPACK)   # cmake/FindSuiteSparse.cmake
find_package(ARPACK REQUIRED)                                        # cmake/FindARPACK.cmake
find_package(NLopt 2.7 REQUIRED)
find_package(Ipopt 3.11 REQUIRED)                                    # cmake/FindIpopt.cmake
find_package(yaml-cpp 0.7 REQUIRED)
find_package(Boost 1.74 REQUIRED COMPONENTS filesystem)              # Boost.DLL (header-only + filesystem)
find_package(nlohmann_json 3.11 REQUIRED)
find_package(CLI11 2.1 REQUIRED)
find_package(fmt 9 REQUIRED)
find_package(OpenMP REQUIRED COMPONENTS CXX)
find_package(Threads REQUIRED)
if(ECMOR_BUILD_TESTS)
  find_package(GTest 1.12 REQUIRED)
endif()
if(ECMOR_BUILD_BENCH)
  find_package(benchmark 1.7 REQUIRED)
endif()
