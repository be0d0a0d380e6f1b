# COBRIDGE_SANITIZE=address -> ASan + UBSan; =thread -> TSan. Applied globally so
# that every object of the project, tests included, is instrumented.
if(COBRIDGE_SANITIZE STREQUAL "address")
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=address,undefined)
elseif(COBRIDGE_SANITIZE STREQUAL "thread")
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
elseif(NOT COBRIDGE_SANITIZE STREQUAL "")
  message(FATAL_ERROR "COBRIDGE_SANITIZE must be '', 'address' or 'thread', not '${COBRIDGE_SANITIZE}'")
endif()
