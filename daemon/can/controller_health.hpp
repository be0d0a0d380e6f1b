// ControllerHealth: the CAN controller's fault confinement state (ISO
// 11898-1 error-active / error-passive / bus-off, plus the error-warning
// level at 96 that Linux reports), its error counters and its restarts, as
// the bus's error frames tell them (Linux can.rst "Network Problem
// Notifications": CAN_ERR_CRTL status, CAN_ERR_BUSOFF, CAN_ERR_RESTARTED,
// CAN_ERR_CNT counters in data[6]/data[7]).
//
// Two sources feed it: the error frames (apply(BusEvent)) and, where the
// driver gives them, the controller's own state and counters read over
// rtnetlink (can/controller_netlink, merged by apply_netlink). vcan has no
// controller: it sends no error frames of its own and no IFLA_CAN data, so
// until error frames arrive the state is `unknown` and `source` none, never
// a guessed error-active.
//
// Thread contract: the bus control thread only (BusEvents from the
// channel, the netlink poll); a value copy for status readers.
#pragma once

#include "can/bus_event.hpp"

#include <cstdint>
#include <string_view>

namespace cobridge::can {

// `unknown`: nothing told the state yet (no error frame, no netlink state).
enum class ControllerState : std::uint8_t { unknown, error_active, error_warning, error_passive, bus_off };

// Where the present figures came from.
enum class HealthSource : std::uint8_t { none, error_frames, netlink };

// What the driver answered to the netlink poll (IFLA_CAN_STATE present?).
enum class DriverReport : std::uint8_t { not_read, state, no_state, failed };

[[nodiscard]] std::string_view to_string(ControllerState s) noexcept;
[[nodiscard]] std::string_view to_string(HealthSource s) noexcept;

struct ControllerHealth {
  ControllerState state = ControllerState::unknown;
  HealthSource source = HealthSource::none;
  DriverReport driver = DriverReport::not_read;
  bool counters_known = false;   // CAN_ERR_CNT or IFLA_CAN_BERR_COUNTER seen
  std::uint16_t tx_errors = 0;   // transmit error counter, as last reported
  std::uint16_t rx_errors = 0;   // receive error counter
  std::uint64_t restarts = 0;    // restarts after bus-off
  std::uint64_t bus_errors = 0;  // protocol violations, missing ACKs, transceiver faults
  std::int64_t since_ns = 0;     // realtime of the last state change, 0 = none yet

  // Applies one event; returns true when the state changed.
  bool apply(const BusEvent& ev) noexcept;
  // Sets the state from whichever source told it; true when it changed.
  bool set_state(ControllerState next, std::int64_t at_ns) noexcept;
};

}  // namespace cobridge::can
