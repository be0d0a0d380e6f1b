// Where the device tests find their inputs: the fixtures next to this file
// and the shipped EDS files in config/devices. The repository is located from
// __FILE__ (CMake compiles with absolute source paths); COBRIDGE_SOURCE_DIR in
// the environment overrides it, e.g. when the tests run from an installed tree.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

namespace cobridge::device::test {

inline std::filesystem::path source_dir() {
  if (const char* env = std::getenv("COBRIDGE_SOURCE_DIR"); env != nullptr && *env != '\0') return env;
  // tests/unit/device/source_paths.hpp -> repository root
  return std::filesystem::path(__FILE__).parent_path().parent_path().parent_path().parent_path();
}

inline std::filesystem::path fixture(const std::string& name) {
  return source_dir() / "tests" / "unit" / "device" / "fixtures" / name;
}

inline std::filesystem::path shipped_devices_dir() { return source_dir() / "config" / "devices"; }

}  // namespace cobridge::device::test
