// ControlCommand: one line of cobridge-sim's control protocol (stdin and the
// Unix control socket speak the same one), parsed. Each command gets exactly
// one reply line, "ok ..." or "error ...".
//
//   list                                  devices: serial, model, bus, node, NMT state
//   power-cycle|power-off|power-on <serial>
//   silence <serial> on|off               cable pulled: no RX, no TX, state kept
//   reboot-on-sdo <serial> <n>            power-cycle when the n-th SDO request from now arrives
//   abort-sdo <serial> <index hex> [code hex]  abort the next SDO request for that object
//   ignore-sdo <serial> <index hex> <n>   leave the next n SDO requests for that object unanswered
//   fault <serial> <kind>                 see fault_kind_names()
//   move <serial> <turns>                 add an offset (turns, may be negative/fractional)
//   flood <iface> <ms>                    highest-priority frames back to back
//   babble <iface> <cob-id hex> <ms>      one identifier back to back
//   bus-error <iface> <kind>              error-warning|error-passive|error-active|bus-off|restarted
//   stats                                 loop and bus counters
//   help, quit
// Thread: the simulator's loop thread (parsing allocates only for messages).
#pragma once

#include "app/bus_fault.hpp"
#include "device/sim_device.hpp"

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace cobridge::sim {

enum class ControlVerb : std::uint8_t {
  list,
  power_cycle,
  power_off,
  power_on,
  silence,
  reboot_on_sdo,
  abort_sdo,
  ignore_sdo,
  fault,
  move,
  flood,
  babble,
  bus_error,
  stats,
  help,
  quit,
};

struct ControlCommand {
  ControlVerb verb = ControlVerb::list;
  std::uint32_t serial = 0;       // device commands
  std::string iface;              // bus commands
  bool on = false;                // silence
  FaultKind fault = FaultKind::clear;
  double turns = 0;               // move
  std::uint32_t cob_id = 0;       // babble
  std::uint32_t duration_ms = 0;  // flood, babble
  std::uint32_t count = 0;        // reboot-on-sdo, ignore-sdo
  std::uint16_t sdo_index = 0;    // abort-sdo, ignore-sdo
  std::uint32_t abort_code = 0;   // abort-sdo (CiA 301 §7.2.4.3.17)
  BusErrorKind bus_error = BusErrorKind::error_passive;
};

struct ControlParse {
  std::optional<ControlCommand> command;
  std::string error;  // the reply text after "error " when command is empty
};

// Parses one line (without its newline). Blank lines are an error too, so that
// every line has exactly one reply.
[[nodiscard]] ControlParse parse_control_command(std::string_view line);

[[nodiscard]] std::optional<FaultKind> parse_fault_kind(std::string_view text) noexcept;
[[nodiscard]] std::string_view to_string(FaultKind kind) noexcept;
// "measurement-error|over-range|...|clear"
[[nodiscard]] std::string fault_kind_names();
// The protocol summary above, for --help and the `help` command.
[[nodiscard]] std::string_view control_help() noexcept;

}  // namespace cobridge::sim
