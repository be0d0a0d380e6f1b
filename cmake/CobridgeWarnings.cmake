# Warnings on the project's own code only (not on third-party headers, which
# come in as SYSTEM includes through their imported targets).
#
# -Werror is for developers and CI (COBRIDGE_WERROR=ON in the presets of
# CMakePresets.json): a distribution build with another compiler version must
# not fail on a new or false warning (GCC 12's -Wrestrict in std::string
# operator+, for one).
option(COBRIDGE_WERROR "Treat the project's warnings as errors (developer presets and CI)" OFF)
add_library(cobridge_warnings INTERFACE)
target_compile_options(cobridge_warnings INTERFACE
  -Wall -Wextra -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
  -Wconversion -Wsign-conversion -Wimplicit-fallthrough
  $<$<BOOL:${COBRIDGE_WERROR}>:-Werror>)
