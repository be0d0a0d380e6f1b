// ControllerNetlink: the CAN controller's own view of its health, as its
// driver reports it over rtnetlink (RTM_GETLINK; Linux can.rst "Netlink
// interface to set/get devices properties": IFLA_INFO_DATA carries
// IFLA_CAN_STATE, enum can_state, and IFLA_CAN_BERR_COUNTER, struct
// can_berr_counter). Read with libnl-route-3, which parses the can-dev
// attributes; only drivers built on can-dev (link kind "can": mcp251x,
// gs_usb, peak_usb, ...) give them. vcan and vxcan give none: the reading
// then says so and the health keeps what the error frames told.
//
// Why poll as well as the error frames: a driver sends a state frame on a
// transition, but counters move between transitions without frames (unless
// berr-reporting is on), and a frame lost to a full socket buffer would
// leave a stale state until the next one.
//
// Thread contract: one ControllerNetlink per bus, owned by the bus control
// thread (read() is a netlink round trip: off the hot path, once a second).
// to_controller_state and apply_netlink are pure, any thread.
#pragma once

#include "base/result.hpp"
#include "can/controller_health.hpp"

#include <cstdint>
#include <string>

struct nl_sock;

namespace cobridge::can {

// What one RTM_GETLINK answer said about an interface's controller.
struct NetlinkReading {
  bool can_device = false;  // IFLA_INFO_KIND "can": a can-dev driver (not vcan / vxcan)
  bool has_state = false;   // IFLA_CAN_STATE present
  std::uint32_t state = 0;  // enum can_state (linux/can/netlink.h)
  bool has_berr = false;    // IFLA_CAN_BERR_COUNTER present (the driver has do_get_berr_counter)
  std::uint16_t tx_errors = 0;
  std::uint16_t rx_errors = 0;
};

// CAN_STATE_ERROR_ACTIVE .. CAN_STATE_BUS_OFF map one to one; STOPPED
// (interface down), SLEEPING and values this build does not know are
// `unknown`: the controller takes no part in the bus, no confinement state.
[[nodiscard]] ControllerState to_controller_state(std::uint32_t kernel_state) noexcept;

// Merges a reading into `health`; true when the state changed. A driver
// with state makes netlink the source; one without (vcan) leaves state and
// counters to the error frames, and if netlink was the source before, the
// figures it gave are withdrawn (unknown) rather than kept as if current.
bool apply_netlink(ControllerHealth& health, const NetlinkReading& reading, std::int64_t now_ns) noexcept;

class ControllerNetlink {
 public:
  ControllerNetlink() = default;
  ~ControllerNetlink();
  ControllerNetlink(const ControllerNetlink&) = delete;
  ControllerNetlink& operator=(const ControllerNetlink&) = delete;

  // One RTM_GETLINK for `interface`. The netlink socket is opened on the
  // first call and kept. Errors name the interface (ENODEV when it is gone).
  [[nodiscard]] Result<NetlinkReading> read(const std::string& interface);

 private:
  Error connect();
  nl_sock* sock_ = nullptr;
};

}  // namespace cobridge::can
