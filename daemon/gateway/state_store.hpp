// StateStore: the gateway's memory of node-ID assignments and applied
// configurations, kept in <state_dir>/assignments.state so that a restart
// needs no new scan and an unchanged device is not rewritten.
//
// One line per device: bus, serial, vendor, product, revision, node-ID,
// configuration fingerprint. Written atomically (temp file + rename).
// Thread: shared by the bus managers; every call takes an internal mutex.
#pragma once

#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

namespace cobridge::gateway {

struct Assignment {
  std::string bus;
  std::uint32_t serial = 0;
  std::uint32_t vendor = 0;
  std::uint32_t product = 0;
  std::uint32_t revision = 0;
  std::uint8_t node_id = 0;
  std::string fingerprint;  // empty = never configured
};

class StateStore {
 public:
  explicit StateStore(std::filesystem::path dir);
  // Reads the file; a missing file is an empty store, a malformed line is
  // reported (file:line) and skipped.
  std::error_code load(std::string* message = nullptr);
  [[nodiscard]] std::optional<Assignment> find(const std::string& bus, std::uint32_t vendor,
                                               std::uint32_t product, std::uint32_t serial) const;
  [[nodiscard]] std::vector<Assignment> on_bus(const std::string& bus) const;
  // Inserts or replaces (same bus + identity) and writes the file.
  std::error_code put(const Assignment& a);
  std::error_code erase(const std::string& bus, std::uint32_t vendor, std::uint32_t product, std::uint32_t serial);
  [[nodiscard]] const std::filesystem::path& path() const noexcept { return path_; }

 private:
  std::error_code save_locked();
  std::filesystem::path dir_;
  std::filesystem::path path_;
  mutable std::mutex mutex_;
  std::vector<Assignment> items_;
};

}  // namespace cobridge::gateway
