# Warnings as errors on the project's own code only (not on third-party headers,
# which come in as SYSTEM includes through their imported targets).
add_library(cobridge_warnings INTERFACE)
target_compile_options(cobridge_warnings INTERFACE
  -Wall -Wextra -Werror -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
  -Wconversion -Wsign-conversion -Wimplicit-fallthrough)
