// WritePolicy: which DCMD commands the Sparkplug output hands to the daemon,
// the same shape as the Modbus output's (writes_enabled, write_allow), but
// matched on what an MQTT 3.1.1 message can honestly tell: the device the
// DCMD topic names and the command it asks for. (Modbus matches the
// client's network address; a subscriber of an MQTT broker never learns
// the publisher's. Who may publish a DCMD is the broker's ACL.)
//
//   writes_enabled = false          every DCMD refused (the default)
//   write_allow    = []             empty: every device, every command
//   write_allow    = ["rot", "mt:preset", "*:store"]
//                                   a device name (every command on it),
//                                   "<device>:<command>", or "*:<command>"
//                                   (every device); command = preset,
//                                   nmt_reset or store
//
// Thread contract: parsed on the control thread; refusal() on the
// publisher thread; const after parsing.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace cobridge::mqtt {

struct WriteRule {
  std::string device;     // "*" = every device
  std::uint8_t kind = 0;  // enum cobridge_command_kind; 0 = every command
};

struct WritePolicy {
  bool enabled = false;
  std::vector<WriteRule> allow;  // empty: everything (when enabled)

  // Why a command `kind` for device `name` is refused; "" when it is taken.
  [[nodiscard]] std::string refusal(std::string_view name, std::uint8_t kind) const;
};

// One write_allow entry; returns "" and fills `out`, or the reason the entry is bad.
[[nodiscard]] std::string parse_write_rule(std::string_view entry, WriteRule& out);

}  // namespace cobridge::mqtt
