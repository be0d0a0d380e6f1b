# COBRIDGE_SANITIZE=address -> ASan + UBSan; =thread -> TSan; =undefined ->
# UBSan alone. Applied globally so that every object of the project, tests
# included, is instrumented.
#
# UBSan alone is the one that runs inside User-Mode Linux (the end-to-end
# tests of the daemon, simulator and plugins, COBRIDGE_TEST_SCOPE=daemon): it
# needs no shadow memory, while ASan's and TSan's fixed shadow ranges lie
# beyond the 39-bit user address space of Debian's UML kernel
# (docs/reliability.md). Every UBSan check is fatal there
# (-fno-sanitize-recover), so a report ends the process and fails the test.
include(CheckCXXCompilerFlag)
if(COBRIDGE_SANITIZE STREQUAL "address")
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=address,undefined)
elseif(COBRIDGE_SANITIZE STREQUAL "thread")
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
elseif(COBRIDGE_SANITIZE STREQUAL "undefined")
  # Checks -fsanitize=undefined leaves out, where the compiler has them.
  set(ubsan_checks undefined)
  foreach(check float-cast-overflow float-divide-by-zero bounds-strict)
    string(MAKE_C_IDENTIFIER "COBRIDGE_HAS_UBSAN_${check}" var)
    set(CMAKE_REQUIRED_LINK_OPTIONS -fsanitize=undefined,${check})
    check_cxx_compiler_flag(-fsanitize=undefined,${check} ${var})
    unset(CMAKE_REQUIRED_LINK_OPTIONS)
    if(${var})
      list(APPEND ubsan_checks ${check})
    endif()
  endforeach()
  list(JOIN ubsan_checks "," ubsan_checks)
  message(STATUS "UBSan checks: ${ubsan_checks}")
  add_compile_options(-fsanitize=${ubsan_checks} -fno-sanitize-recover=all -fno-omit-frame-pointer)
  add_link_options(-fsanitize=${ubsan_checks})
elseif(NOT COBRIDGE_SANITIZE STREQUAL "")
  message(FATAL_ERROR "COBRIDGE_SANITIZE must be '', 'address', 'thread' or 'undefined', not '${COBRIDGE_SANITIZE}'")
endif()
