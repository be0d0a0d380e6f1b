// DeviceIndexPool: the device indices (cobridge_sample.device_index, the
// Modbus slot and DDS instance a device is read by) of devices the
// configuration does not name. A configured device's index is its position
// in the configuration (< kFirst); the others share one bounded range above
// it, across every bus: a device keeps its index while it is known, gives it
// back when it is forgotten, and the index is reused. When the range is used
// up a device gets none (and is not published) rather than one that collides
// or that an output cannot hold (the DDS plugin has 1016 slots).
// Threads: every bus's control thread (a mutex; never on the hot path).
#pragma once

#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace cobridge::outputs {

class DeviceIndexPool {
 public:
  static constexpr std::uint16_t kFirst = 1000;  // configured devices are below
  static constexpr std::uint16_t kEnd = 1016;    // the DDS plugin's slot count

  // The index of `key` (e.g. "<bus>/<name>"), the same on every call until release().
  [[nodiscard]] std::optional<std::uint16_t> acquire(const std::string& key);
  void release(const std::string& key);
  [[nodiscard]] std::size_t in_use() const;

 private:
  mutable std::mutex mutex_;
  std::map<std::string, std::uint16_t> taken_;
  std::vector<std::uint16_t> freed_;  // given back, reused first
  std::uint16_t next_ = kFirst;
};

}  // namespace cobridge::outputs
