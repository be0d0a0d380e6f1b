// NvStore: the non-volatile memory of one simulated encoder, kept per serial
// number in a small text file under the simulator's state directory, so a
// power cycle (or a restarted simulator) comes back with exactly what was
// stored and nothing else.
//
// Two images live in the file: `params`, what 0x1010 'save' / LSS store /
// ifm 0x2300 wrote (erased by 'kill'), and `history`, the condition-
// monitoring recorder that only 0x2300 sub-commands clear (E§5.8). Each line
// is `index:sub=hex` (numeric values as their little-endian bit pattern)
// under a `[params]` or `[history]` header. Saving writes a temporary file
// and renames it over the old one, so a simulator killed at any point leaves
// either the old or the new image, never half of one (the host's own crash
// is not simulated: no fsync, which would hold every device's answers).
// Thread: the device's thread; file I/O, called off the per-frame path
// (store commands, power on).
#pragma once

#include "base/error.hpp"

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <system_error>

namespace cobridge::sim {

class NvImage {
 public:
  void set(std::uint16_t index, std::uint8_t sub, std::uint64_t raw) { values_[key(index, sub)] = raw; }
  void erase(std::uint16_t index, std::uint8_t sub) { values_.erase(key(index, sub)); }
  [[nodiscard]] std::optional<std::uint64_t> get(std::uint16_t index, std::uint8_t sub) const;
  void clear() noexcept { values_.clear(); }
  [[nodiscard]] bool empty() const noexcept { return values_.empty(); }
  [[nodiscard]] const std::map<std::uint32_t, std::uint64_t>& values() const noexcept { return values_; }

  [[nodiscard]] static constexpr std::uint32_t key(std::uint16_t index, std::uint8_t sub) noexcept {
    return (std::uint32_t{index} << 8) | sub;
  }

  friend bool operator==(const NvImage&, const NvImage&) = default;

 private:
  std::map<std::uint32_t, std::uint64_t> values_;
};

struct NvContents {
  NvImage params;
  NvImage history;
};

class NvStore {
 public:
  // An empty path makes the store volatile: load finds nothing, save succeeds.
  explicit NvStore(std::filesystem::path path = {}) : path_(std::move(path)) {}

  [[nodiscard]] const std::filesystem::path& path() const noexcept { return path_; }

  // A missing file is an empty memory (a new device), not an error. A file
  // that cannot be parsed is an error (kInvalidArgument, where "file:line");
  // an I/O failure has the file as its where and the errno as its code.
  [[nodiscard]] Error load(NvContents& out) const;
  [[nodiscard]] Error save(const NvContents& contents) const;

 private:
  std::filesystem::path path_;
};

}  // namespace cobridge::sim
