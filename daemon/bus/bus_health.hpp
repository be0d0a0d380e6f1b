// BusHealth: one bus's health as the outputs are told it (plugin ABI 5
// on_bus, through BusObserver::on_bus_health): whether the interface is
// open, its CAN controller (can/controller_health: state, error counters,
// restarts, where the figures came from) and its error frame count.
//
// BusHealthGate decides when a new BusHealth is worth telling: a change of
// the controller's state, of the figures' source or of the open flag goes
// at once; counters alone (they move with every bus error on a noisy bus)
// at most once per period, the latest figures then. So a plugin sees every
// transition and no flood.
//
// Thread contract: the bus control thread only; time is passed in.
#pragma once

#include "can/controller_health.hpp"
#include "canopen/clock.hpp"

#include <cstdint>
#include <optional>

namespace cobridge::bus {

struct BusHealth {
  bool open = false;
  can::ControllerHealth controller;
  std::uint64_t error_frames = 0;  // error frames received on the bus (SocketCAN)
};

class BusHealthGate {
 public:
  explicit BusHealthGate(canopen::Duration period) : period_(period) {}

  // True when `health` should be told now (it is then remembered as told).
  [[nodiscard]] bool due(const BusHealth& health, canopen::TimePoint now);
  // When a held-back change of counters may go; kNever when none waits.
  [[nodiscard]] canopen::TimePoint next() const noexcept { return held_ ? told_at_ + period_ : canopen::kNever; }

 private:
  canopen::Duration period_;
  std::optional<BusHealth> told_;
  canopen::TimePoint told_at_{};
  bool held_ = false;
};

}  // namespace cobridge::bus
