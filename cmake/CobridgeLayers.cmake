# The walls between the daemon's layers (issue 13).
#
# Every layer's headers are included by their layer name ("canopen/sdo_client.hpp").
# Exporting daemon/ itself would let any target include any layer. Instead each
# layer exports a build-tree include root, build/layers/<layer>/, that holds one
# symlink <layer> -> daemon/<layer>: "canopen/..." then resolves only in targets
# that link cobridge_canopen (directly or through a PUBLIC link).
#
# cobridge_layer(<layer>) gives target cobridge_<layer> that include root.
function(cobridge_layer layer)
  set(root ${PROJECT_BINARY_DIR}/layers/${layer})
  file(MAKE_DIRECTORY ${root})
  file(CREATE_LINK ${PROJECT_SOURCE_DIR}/daemon/${layer} ${root}/${layer} SYMBOLIC)
  target_include_directories(cobridge_${layer} PUBLIC $<BUILD_INTERFACE:${root}>)
  set_property(GLOBAL APPEND PROPERTY COBRIDGE_LAYERS ${layer})
endfunction()
