// StateStore: the gateway's memory of node-ID assignments and applied
// configurations, kept in <state_dir>/assignments.state so that a restart
// needs no new scan and an unchanged device is not rewritten.
//
// One line per device: bus, serial, vendor, product, revision, node-ID,
// configuration fingerprint, as `key=value` fields separated by blanks
// (values percent-encoded where they hold blanks, '%', '=' or '#'); '#'
// starts a comment line. Written atomically (temp file + fsync + rename +
// fsync of the directory), so a crash leaves the old or the new file, never a
// torn one. A line that cannot be read is reported with file:line and skipped;
// the rest of the file still counts.
//
// Thread: shared by the bus managers; every call takes an internal mutex.
// File I/O happens inside put()/erase(): control threads only, never the hot
// path.
#pragma once

#include "base/result.hpp"

#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
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

  friend bool operator==(const Assignment&, const Assignment&) = default;
};

enum class StateStoreErrc {
  malformed_lines = 1,  // load(): some lines were skipped (see the message)
  read_failed,          // load(): the file exists but cannot be read
  invalid_assignment,   // put(): empty bus name or node-ID outside 0..127
};
[[nodiscard]] const std::error_category& state_store_category() noexcept;
[[nodiscard]] std::error_code make_error_code(StateStoreErrc e) noexcept;

class StateStore {
 public:
  static constexpr const char* kFileName = "assignments.state";

  explicit StateStore(std::filesystem::path dir);
  // Reads the file; a missing file is an empty store, a malformed line is
  // reported (file:line) and skipped. When lines were skipped: kInvalidArgument
  // with code malformed_lines, where = the file and every problem in the
  // message, one per line (the good lines are loaded all the same); a file
  // that cannot be read: kFailed with read_failed. The caller logs it.
  [[nodiscard]] Error load();
  [[nodiscard]] std::optional<Assignment> find(const std::string& bus, std::uint32_t vendor,
                                               std::uint32_t product, std::uint32_t serial) const;
  [[nodiscard]] std::vector<Assignment> on_bus(const std::string& bus) const;
  // Inserts or replaces (same bus + identity) and writes the file. The
  // directory is created if missing. Writing nothing when the entry is
  // unchanged spares the disk on every reconfiguration.
  // A failure: kInvalidArgument (code invalid_assignment) for an empty bus
  // name or a node-ID above 127, else kFailed with the errno; where = the
  // file. The store is unchanged then.
  Error put(const Assignment& a);
  Error erase(const std::string& bus, std::uint32_t vendor, std::uint32_t product, std::uint32_t serial);
  [[nodiscard]] const std::filesystem::path& path() const noexcept { return path_; }

  // The text form of one line and its parser, exposed for tests.
  [[nodiscard]] static std::string format_line(const Assignment& a);
  // The assignment of one line, or why it is refused (kInvalidArgument).
  [[nodiscard]] static Result<Assignment> parse_line(std::string_view line);

 private:
  Error save_locked();
  std::filesystem::path dir_;
  std::filesystem::path path_;
  mutable std::mutex mutex_;
  std::vector<Assignment> items_;
};

}  // namespace cobridge::gateway

template <>
struct std::is_error_code_enum<cobridge::gateway::StateStoreErrc> : std::true_type {};
