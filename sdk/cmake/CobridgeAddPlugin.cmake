# cobridge_sdk_add_plugin(<name> SOURCES ...): libcobridge_<name>.so, the file
# name the daemon's plugin host looks for, with hidden visibility so that only
# the entry point (COBRIDGE_PLUGIN_EXPORT) is exported, and unresolved symbols
# caught at link time rather than at dlopen. Links cobridge::sdk.
function(cobridge_sdk_add_plugin name)
  cmake_parse_arguments(ARG "" "" "SOURCES" ${ARGN})
  add_library(${name} MODULE ${ARG_SOURCES})
  set_target_properties(${name} PROPERTIES PREFIX "lib" OUTPUT_NAME cobridge_${name}
    C_VISIBILITY_PRESET hidden CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON)
  target_link_libraries(${name} PRIVATE cobridge::sdk)
  target_link_options(${name} PRIVATE -Wl,--no-undefined)
endfunction()
