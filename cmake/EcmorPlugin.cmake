# ecmor_add_plugin(<name> SOURCES ... [LIBRARIES ...])
# Builds a reducer plugin as a MODULE library loadable by the ecmor driver: C++20, hidden
# visibility (only the ECMOR_PLUGIN entry points are exported), linked with --no-undefined so a
# missing symbol fails at link time, not at load time. Used in-tree and, installed with ecmor's
# CMake package, by out-of-tree plugins (find_package(ecmor) includes this file).
#
# Where the library goes:
#  * build: ${ECMOR_PLUGIN_OUTPUT_DIR} if set (in-tree: build/lib/ecmor/plugins, where the driver
#    looks), otherwise CMake's default, the binary directory of the calling CMakeLists.txt (an
#    out-of-tree project's own build directory);
#  * install: ${ECMOR_PLUGIN_INSTALL_DIR} if set (in-tree: lib/ecmor/plugins; out of tree the
#    package sets the same relative default, so `cmake --install . --prefix P` puts the plugin in
#    P/lib/ecmor/plugins, the directory an ecmor installed in P searches by itself).
function(ecmor_add_plugin name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBRARIES" ${ARGN})
  if(NOT ARG_SOURCES)
    message(FATAL_ERROR "ecmor_add_plugin(${name}): no SOURCES given")
  endif()
  add_library(${name} MODULE ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ecmor::core ${ARG_LIBRARIES})
  # The public headers need C++20 (std::span); ecmor itself is built as ISO C++20, no extensions.
  target_compile_features(${name} PRIVATE cxx_std_20)
  set_target_properties(${name} PROPERTIES PREFIX "lib" CXX_EXTENSIONS OFF
    CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON)
  if(DEFINED ECMOR_PLUGIN_OUTPUT_DIR)
    set_target_properties(${name} PROPERTIES LIBRARY_OUTPUT_DIRECTORY "${ECMOR_PLUGIN_OUTPUT_DIR}")
  endif()
  target_link_options(${name} PRIVATE "LINKER:--no-undefined")
  if(TARGET ecmor_core)
    # In the ecmor tree. An installed plugin lives in <prefix>/lib/ecmor/plugins and finds
    # libecmor_core two directories up; the project-wide $ORIGIN/../lib suits bin/ only.
    file(RELATIVE_PATH to_libdir "/${ECMOR_PLUGIN_INSTALL_DIR}" "/${CMAKE_INSTALL_LIBDIR}")
    string(REGEX REPLACE "/$" "" to_libdir "${to_libdir}")
    set_target_properties(${name} PROPERTIES INSTALL_RPATH "$ORIGIN/${to_libdir}")
  elseif(DEFINED ECMOR_LIBRARY_DIR)
    # Out of tree: an installed plugin keeps finding the libecmor_core it was built against (the
    # driver has it loaded already; this is for ldd and other hosts).
    set_target_properties(${name} PROPERTIES INSTALL_RPATH "${ECMOR_LIBRARY_DIR}")
  endif()
  if(DEFINED ECMOR_PLUGIN_INSTALL_DIR)
    install(TARGETS ${name} LIBRARY DESTINATION "${ECMOR_PLUGIN_INSTALL_DIR}")
  endif()
  if(COMMAND ecmor_set_warnings)
    ecmor_set_warnings(${name})
  endif()
endfunction()
