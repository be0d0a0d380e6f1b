# The walls between the daemon's layers.
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

# cobridge_write_target_graph(<file>): the build's own target graph as JSON,
# for scripts/check-layers and scripts/layer-graph (written at generate time,
# so it is what the build really links, not what a comment says):
#   {"source_dir": ..., "layers": [...],
#    "targets": {"<name>": {"type", "source_dir", "sources": [...],
#                "links": [...], "interface_links": [...], "includes": [...]}}}
# Call it last in the top-level CMakeLists.txt.
function(cobridge_collect_targets dir out)
  get_property(targets DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  get_property(subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(sub IN LISTS subdirs)
    cobridge_collect_targets(${sub} sub_targets)
    list(APPEND targets ${sub_targets})
  endforeach()
  set(${out} ${targets} PARENT_SCOPE)
endfunction()

function(cobridge_write_target_graph file)
  cobridge_collect_targets(${PROJECT_SOURCE_DIR} targets)
  get_property(layers GLOBAL PROPERTY COBRIDGE_LAYERS)
  list(JOIN layers "\",\"" layer_json)
  set(entries)
  foreach(t IN LISTS targets)
    get_target_property(type ${t} TYPE)
    if(NOT type MATCHES "^(STATIC_LIBRARY|SHARED_LIBRARY|MODULE_LIBRARY|OBJECT_LIBRARY|INTERFACE_LIBRARY|EXECUTABLE)$")
      continue()
    endif()
    get_target_property(dir ${t} SOURCE_DIR)
    set(p "$<TARGET_PROPERTY:${t},")
    set(q "\"")
    # Each list property as a JSON array of strings (an empty list gives [""],
    # which the scripts drop).
    set(sources "[${q}$<JOIN:${p}SOURCES>,${q}$<COMMA>${q}>${q}]")
    set(links "[${q}$<JOIN:${p}LINK_LIBRARIES>,${q}$<COMMA>${q}>${q}]")
    set(ilinks "[${q}$<JOIN:${p}INTERFACE_LINK_LIBRARIES>,${q}$<COMMA>${q}>${q}]")
    if(type STREQUAL "INTERFACE_LIBRARY")
      set(sources "[]")
      set(links "[]")
      set(includes "[${q}$<JOIN:${p}INTERFACE_INCLUDE_DIRECTORIES>,${q}$<COMMA>${q}>${q}]")
    else()
      set(includes "[${q}$<JOIN:${p}INCLUDE_DIRECTORIES>,${q}$<COMMA>${q}>${q}]")
    endif()
    list(APPEND entries "${q}${t}${q}: {${q}type${q}: ${q}${type}${q}, ${q}source_dir${q}: ${q}${dir}${q}, ${q}sources${q}: ${sources}, ${q}links${q}: ${links}, ${q}interface_links${q}: ${ilinks}, ${q}includes${q}: ${includes}}")
  endforeach()
  list(JOIN entries ",\n  " body)
  file(GENERATE OUTPUT ${file} CONTENT
    "{\"source_dir\": \"${PROJECT_SOURCE_DIR}\", \"binary_dir\": \"${PROJECT_BINARY_DIR}\", \"layers\": [\"${layer_json}\"],\n \"targets\": {\n  ${body}\n}}\n")
endfunction()
