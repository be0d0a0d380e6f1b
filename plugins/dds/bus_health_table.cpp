#include "dds/bus_health_table.hpp"

#include <algorithm>
#include <cstddef>

namespace cobridge::dds {
namespace {

const char* source_name(std::uint8_t source) noexcept {
  switch (source) {
    case COBRIDGE_SOURCE_ERROR_FRAMES: return "error frames";
    case COBRIDGE_SOURCE_NETLINK: return "netlink";
    default: return "none";
  }
}

}  // namespace

bool BusHealthTable::update(const cobridge_bus_info& info) {
  if (info.struct_size < offsetof(cobridge_bus_info, bus_name) + sizeof(info.bus_name)) return false;
  BusHealthEntry e;
  e.bus_index = info.bus_index;
  e.bus_name = info.bus_name != nullptr ? info.bus_name : "";
  e.open = info.open != 0;
  e.controller_state = info.state <= COBRIDGE_CONTROLLER_BUS_OFF ? info.state : std::uint8_t{COBRIDGE_CONTROLLER_UNKNOWN};
  e.source = source_name(info.source);
  e.counters_known = info.counters_known != 0;
  e.tx_errors = e.counters_known ? info.tx_errors : 0;
  e.rx_errors = e.counters_known ? info.rx_errors : 0;
  e.restarts = info.restarts;
  e.error_frames = info.error_frames;
  e.since_ns = info.since_ns;
  const std::lock_guard lock(mutex_);
  const auto at = std::lower_bound(buses_.begin(), buses_.end(), e.bus_index,
                                   [](const BusHealthEntry& b, std::uint8_t index) { return b.bus_index < index; });
  if (at != buses_.end() && at->bus_index == e.bus_index) {
    *at = std::move(e);
  } else {
    buses_.insert(at, std::move(e));
  }
  return true;
}

std::vector<BusHealthEntry> BusHealthTable::snapshot() const {
  const std::lock_guard lock(mutex_);
  return buses_;
}

}  // namespace cobridge::dds
