# Installed layout: bin/ecmor, lib/libecmor_core.so, lib/ecmor/plugins/*.so, include/ecmor/*.hpp,
# lib/cmake/ecmor/ecmorConfig.cmake (with ecmor_add_plugin) for out-of-tree plugins.
include(CMakePackageConfigHelpers)
install(TARGETS ecmor_core EXPORT ecmorTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(DIRECTORY core/include/ecmor DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(FILES "${PROJECT_BINARY_DIR}/core/include/ecmor/export.hpp"
              "${PROJECT_BINARY_DIR}/core/include/ecmor/version.hpp"
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/ecmor)
install(EXPORT ecmorTargets NAMESPACE ecmor:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/ecmor)
configure_package_config_file(cmake/ecmorConfig.cmake.in
  "${PROJECT_BINARY_DIR}/ecmorConfig.cmake" INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/ecmor)
write_basic_package_version_file("${PROJECT_BINARY_DIR}/ecmorConfigVersion.cmake"
  COMPATIBILITY SameMinorVersion)
install(FILES "${PROJECT_BINARY_DIR}/ecmorConfig.cmake" "${PROJECT_BINARY_DIR}/ecmorConfigVersion.cmake"
  cmake/EcmorPlugin.cmake DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/ecmor)
