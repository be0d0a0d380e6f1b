// DeviceCommand: an action an output plugin asks of one device (plugin ABI 2,
// cobridge_host_api.submit_command): a preset, an NMT reset, a store. The
// plugin host turns the C struct into one of these, the output pipeline
// routes it to the device's bus manager, whose control thread runs it as a
// small plan (config_plan.hpp: make_command_plan) and reports a
// CommandOutcome, which travels back to every plugin as a COMMAND sample.
//
// Thread contract: plain values; built on a plugin's thread, executed on
// the bus's control thread. Off the hot path.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

namespace cobridge::bus {

// Values are plugin.h's enum cobridge_command_kind (checked in the .cpp).
enum class CommandKind : std::uint8_t { preset = 1, nmt_reset = 2, store = 3 };

// Values are plugin.h's enum cobridge_command_status.
enum class CommandStatus : std::uint8_t {
  ok = 0,
  unknown_device = 1,
  offline = 2,
  busy = 3,
  unsupported = 4,
  invalid_value = 5,
  refused = 6,  // SDO abort from the device
  timeout = 7,
  failed = 8,
};

struct DeviceCommand {
  std::string device;  // configured device name
  CommandKind kind = CommandKind::preset;
  std::int64_t value = 0;  // preset: the position in counts
  std::uint32_t tag = 0;   // the submitter's, echoed in the outcome
  std::string source;      // who submitted it: "plugin modbus" (its instance name)
};

struct CommandOutcome {
  CommandStatus status = CommandStatus::ok;
  std::uint32_t abort_code = 0;  // CiA 301 SDO abort code when refused
  std::string message;           // for the log; empty on success
};

// nullopt for a value plugin.h does not define.
[[nodiscard]] std::optional<CommandKind> command_kind(std::uint8_t raw) noexcept;
[[nodiscard]] const char* to_string(CommandKind kind) noexcept;
[[nodiscard]] const char* to_string(CommandStatus status) noexcept;

}  // namespace cobridge::bus
