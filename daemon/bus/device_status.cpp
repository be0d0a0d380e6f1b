#include "bus/device_status.hpp"

namespace cobridge::bus {

const char* to_string(DeviceState s) noexcept {
  switch (s) {
    case DeviceState::expected: return "expected";
    case DeviceState::identified: return "identified";
    case DeviceState::commissioning: return "commissioning";
    case DeviceState::configuring: return "configuring";
    case DeviceState::operational: return "operational";
    case DeviceState::offline: return "offline";
    case DeviceState::failed: return "failed";
    case DeviceState::stopped: return "stopped";
  }
  return "?";
}

}  // namespace cobridge::bus
