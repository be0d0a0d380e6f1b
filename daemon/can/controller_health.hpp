// ControllerHealth: the CAN controller's fault confinement state (ISO
// 11898-1 error-active / error-passive / bus-off, plus the error-warning
// level at 96 that Linux reports), its error counters and its restarts, as
// the bus's error frames tell them (Linux can.rst "Network Problem
// Notifications": CAN_ERR_CRTL status, CAN_ERR_BUSOFF, CAN_ERR_RESTARTED,
// CAN_ERR_CNT counters in data[6]/data[7]).
//
// vcan has no controller and sends no error frames of its own; a real
// adapter's driver sends them on every state change (and, with
// berr-reporting, on bus errors). The state is what the last state frame
// said: a driver that reports nothing leaves it at error-active.
//
// Thread contract: the bus control thread only (BusEvents from the
// channel); a value copy for status readers.
#pragma once

#include "can/bus_event.hpp"

#include <cstdint>
#include <string_view>

namespace cobridge::can {

enum class ControllerState : std::uint8_t { error_active, error_warning, error_passive, bus_off };

[[nodiscard]] std::string_view to_string(ControllerState s) noexcept;

struct ControllerHealth {
  ControllerState state = ControllerState::error_active;
  bool counters_known = false;   // a frame with CAN_ERR_CNT was seen
  std::uint8_t tx_errors = 0;    // transmit error counter, as last reported
  std::uint8_t rx_errors = 0;    // receive error counter
  std::uint64_t restarts = 0;    // restarts after bus-off
  std::uint64_t bus_errors = 0;  // protocol violations, missing ACKs, transceiver faults
  std::int64_t since_ns = 0;     // realtime of the last state change, 0 = none yet

  // Applies one event; returns true when the state changed.
  bool apply(const BusEvent& ev) noexcept;
};

}  // namespace cobridge::can
