# ecmor_add_plugin(<name> SOURCES ... [LIBRARIES ...])
# Builds a reducer plugin as a MODULE library loadable by the ecmor driver: hidden visibility (only the
# ECMOR_PLUGIN entry points are exported), linked with --no-undefined so a missing symbol fails at link
# time, placed where the driver looks for plugins. Used in-tree and, installed, by out-of-tree plugins.
function(ecmor_add_plugin name)
  cmake_parse_arguments(ARG "" "" "SOURCES;LIBRARIES" ${ARGN})
  add_library(${name} MODULE ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ecmor::core ${ARG_LIBRARIES})
  set_target_properties(${name} PROPERTIES PREFIX "lib" CXX_VISIBILITY_PRESET hidden
    VISIBILITY_INLINES_HIDDEN ON)
  if(DEFINED ECMOR_PLUGIN_OUTPUT_DIR)
    set_target_properties(${name} PROPERTIES LIBRARY_OUTPUT_DIRECTORY "${ECMOR_PLUGIN_OUTPUT_DIR}")
  endif()
  target_link_options(${name} PRIVATE "LINKER:--no-undefined")
  if(DEFINED ECMOR_PLUGIN_INSTALL_DIR)
    install(TARGETS ${name} LIBRARY DESTINATION "${ECMOR_PLUGIN_INSTALL_DIR}")
  endif()
  if(COMMAND ecmor_set_warnings)
    ecmor_set_warnings(${name})
  endif()
endfunction()
