# Installed layout: bin/ecmor, lib/libecmor_core.so, lib/ecmor/plugins/*.so (the bundled plugins,
# installed by ecmor_add_plugin), include/ecmor/*.hpp, lib/cmake/ecmor/ecmorConfig.cmake (with
# ecmor_add_plugin, the imported driver ecmor::ecmor and ECMOR_EXECUTABLE) for out-of-tree plugins.
# The executable finds libecmor_core through RPATH $ORIGIN/../lib (top-level CMakeLists.txt), the
# plugins through $ORIGIN/../.. (EcmorPlugin.cmake).
include(CMakePackageConfigHelpers)
# (No INCLUDES DESTINATION: ecmor_core's INSTALL_INTERFACE include directory already says it.)
install(TARGETS ecmor_core EXPORT ecmorTargets LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
if(TARGET ecmor_petsc)
  install(TARGETS ecmor_petsc LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})  # backend module
endif()
install(DIRECTORY core/include/ecmor DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(FILES "${PROJECT_BINARY_DIR}/core/include/ecmor/export.hpp"
              "${PROJECT_BINARY_DIR}/core/include/ecmor/version.hpp"
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/ecmor)
install(EXPORT ecmorTargets NAMESPACE ecmor:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/ecmor)
# PATH_VARS: the config computes these from its own location, so the prefix can be moved.
configure_package_config_file(cmake/ecmorConfig.cmake.in
  "${PROJECT_BINARY_DIR}/ecmorConfig.cmake" INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/ecmor
  PATH_VARS CMAKE_INSTALL_BINDIR CMAKE_INSTALL_LIBDIR ECMOR_PLUGIN_INSTALL_DIR)
write_basic_package_version_file("${PROJECT_BINARY_DIR}/ecmorConfigVersion.cmake"
  COMPATIBILITY SameMinorVersion)
install(FILES "${PROJECT_BINARY_DIR}/ecmorConfig.cmake" "${PROJECT_BINARY_DIR}/ecmorConfigVersion.cmake"
  cmake/EcmorPlugin.cmake DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/ecmor)
