// BusHealthTable: every bus's health as the daemon told it (plugin ABI 5
// on_bus), kept for GatewayStatus.bus_health (docs/dds.md "GatewayStatus").
//
// Thread contract: update() on the dispatcher thread (on_bus); snapshot()
// on the presence thread. Off the hot path: one mutex, rare calls (a state
// change, counters at most once a second per bus).
#pragma once

#include <cobridge/plugin.h>

#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

namespace cobridge::dds {

// One bus as GatewayStatus.bus_health carries it (cobridge.idl BusHealth).
struct BusHealthEntry {
  std::uint8_t bus_index = 0;
  std::string bus_name;
  bool open = false;
  std::uint8_t controller_state = COBRIDGE_CONTROLLER_UNKNOWN;
  std::string source = "none";
  bool counters_known = false;
  std::uint16_t tx_errors = 0;
  std::uint16_t rx_errors = 0;
  std::uint64_t restarts = 0;
  std::uint64_t error_frames = 0;
  std::uint64_t since_ns = 0;
  friend bool operator==(const BusHealthEntry&, const BusHealthEntry&) = default;
};

class BusHealthTable {
 public:
  // Records one bus's health (replacing what it said before); false when
  // the info is too short or malformed (then nothing changes).
  bool update(const cobridge_bus_info& info);
  // Every bus told so far, by bus index.
  [[nodiscard]] std::vector<BusHealthEntry> snapshot() const;

 private:
  mutable std::mutex mutex_;
  std::vector<BusHealthEntry> buses_;  // sorted by bus_index
};

}  // namespace cobridge::dds
