// The precompiled header of every test executable (tests/CMakeLists.txt).
