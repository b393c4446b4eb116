# Installed layout: bin/ecmor, lib/libecmor_core.so, lib/libecmor_interop.so (data exchange with
# other tools, interop/), lib/ecmor/plugins/*.so (the bundled plugins, installed by
# ecmor_add_plugin), include/ecmor/*.hpp (the interop headers in include/ecmor/interop/),
# lib/cmake/ecmor/ecmorConfig.cmake (ecmor::core, ecmor::interop, ecmor_add_plugin, the imported
# driver ecmor::ecmor and ECMOR_EXECUTABLE) for out-of-tree plugins and tools.
# The executable finds the libraries through RPATH $ORIGIN/../lib (top-level CMakeLists.txt), the
# plugins libecmor_core through $ORIGIN/../.. (EcmorPlugin.cmake).
include(CMakePackageConfigHelpers)
# (No INCLUDES DESTINATION: the targets' INSTALL_INTERFACE include directories already say it.)
install(TARGETS ecmor_core ecmor_interop EXPORT ecmorTargets
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
if(TARGET ecmor_petsc)
  install(TARGETS ecmor_petsc LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})  # backend module
endif()
install(DIRECTORY core/include/ecmor interop/include/ecmor
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(FILES "${PROJECT_BINARY_DIR}/core/include/ecmor/export.hpp"
              "${PROJECT_BINARY_DIR}/core/include/ecmor/version.hpp"
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/ecmor)
install(FILES "${PROJECT_BINARY_DIR}/interop/include/ecmor/interop/export.hpp"
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/ecmor/interop)
install(EXPORT ecmorTargets NAMESPACE ecmor:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/ecmor)
# PATH_VARS: the config computes these from its own location, so the prefix can be moved.
configure_package_config_file(cmake/ecmorConfig.cmake.in
  "${PROJECT_BINARY_DIR}/ecmorConfig.cmake" INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/ecmor
  PATH_VARS CMAKE_INSTALL_BINDIR CMAKE_INSTALL_LIBDIR ECMOR_PLUGIN_INSTALL_DIR)
write_basic_package_version_file("${PROJECT_BINARY_DIR}/ecmorConfigVersion.cmake"
  COMPATIBILITY SameMinorVersion)
install(FILES "${PROJECT_BINARY_DIR}/ecmorConfig.cmake" "${PROJECT_BINARY_DIR}/ecmorConfigVersion.cmake"
  cmake/EcmorPlugin.cmake DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/ecmor)
