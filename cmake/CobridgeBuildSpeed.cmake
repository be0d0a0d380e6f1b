# Build speed: CI builds the tree three times on two cores.
#
# COBRIDGE_UNITY: libraries compile as unity batches (CMake UNITY_BUILD), so
#   the heavy headers (spdlog, fmt, toml++, the standard library) are parsed
#   once a batch instead of once a file. Test executables opt out (one file
#   each, and their own precompiled header, tests/CMakeLists.txt).
# ccache: used when installed (scripts/setup-deps installs it); its directory
#   is CCACHE_DIR, or /var/cache/cobridge-ccache when unset (kept between
#   runs on one machine; the first, cold, run gains nothing).
# COBRIDGE_LLD: executables and plugins link with lld when the compiler
#   takes it (scripts/setup-deps installs it): about 170 links a tree, each
#   2.3x to 3.7x quicker than GNU ld (a unit test 1.15 s instead of 2.7 s,
#   cobridged 1.2 s instead of 4.3 s, measured beside a build).
option(COBRIDGE_UNITY "Compile libraries as unity batches" ON)
set(COBRIDGE_UNITY_BATCH 8 CACHE STRING "Files per unity batch")
if(COBRIDGE_UNITY)
  set(CMAKE_UNITY_BUILD ON)
  set(CMAKE_UNITY_BUILD_BATCH_SIZE ${COBRIDGE_UNITY_BATCH})
endif()

option(COBRIDGE_CCACHE "Compile through ccache when it is installed" ON)
find_program(COBRIDGE_CCACHE_PROGRAM ccache)
if(COBRIDGE_CCACHE AND COBRIDGE_CCACHE_PROGRAM)
  set(ccache_dir "$ENV{CCACHE_DIR}")
  if(NOT ccache_dir)
    set(ccache_dir /var/cache/cobridge-ccache)
  endif()
  # No CCACHE_BASEDIR: it hands the compiler relative paths, and tests find
  # their fixtures through __FILE__. A clone in the same folder (as CI makes
  # it) hits what the previous one compiled.
  set(launcher ${CMAKE_COMMAND} -E env CCACHE_DIR=${ccache_dir}
               CCACHE_SLOPPINESS=pch_defines,time_macros,include_file_mtime,include_file_ctime
               ${COBRIDGE_CCACHE_PROGRAM})
  set(CMAKE_C_COMPILER_LAUNCHER ${launcher})
  set(CMAKE_CXX_COMPILER_LAUNCHER ${launcher})
  message(STATUS "ccache: ${COBRIDGE_CCACHE_PROGRAM} (CCACHE_DIR ${ccache_dir})")
endif()

option(COBRIDGE_LLD "Link with lld when the compiler takes -fuse-ld=lld" ON)
if(COBRIDGE_LLD)
  include(CheckLinkerFlag)
  check_linker_flag(CXX -fuse-ld=lld COBRIDGE_HAVE_LLD)
  if(COBRIDGE_HAVE_LLD)
    add_link_options(-fuse-ld=lld)
  endif()
endif()
