// TempDir: a fresh directory /tmp/cobridge-<name>-<pid>, empty at the start
// and removed with everything in it when the TempDir goes, for the tests of
// the gateway's own files (state, journal).
//
// Thread: the test's.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>

namespace cobridge::test {

class TempDir {
 public:
  explicit TempDir(const std::string& name)
      : path_(std::filesystem::temp_directory_path() / ("cobridge-" + name + "-" + std::to_string(::getpid()))) {
    std::filesystem::remove_all(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace cobridge::test
