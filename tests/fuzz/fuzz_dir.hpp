// fresh_dir: a new empty directory for one fuzz input of a target that
// works on the gateway's files (state store, timeline journal), under
// /dev/shm when there is one: the writers fsync their files and directory,
// and a disk would make every input cost milliseconds. The caller removes
// it when the input passed (a failing input's directory stays for a look).
// Thread: test code, single-threaded.
#pragma once

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace cobridge::fuzz {

inline std::filesystem::path fresh_dir(const char* target) {
  const std::filesystem::path base = std::filesystem::exists("/dev/shm") ? "/dev/shm" : "/tmp";
  std::string name = (base / ("cobridge-" + std::string(target) + "-fuzz-XXXXXX")).string();
  if (::mkdtemp(name.data()) == nullptr) std::abort();
  return name;
}

}  // namespace cobridge::fuzz
