#include "bus/device_command.hpp"

#include <cobridge/plugin.h>

namespace cobridge::bus {

static_assert(static_cast<int>(CommandKind::preset) == COBRIDGE_COMMAND_PRESET);
static_assert(static_cast<int>(CommandKind::nmt_reset) == COBRIDGE_COMMAND_NMT_RESET);
static_assert(static_cast<int>(CommandKind::store) == COBRIDGE_COMMAND_STORE);
static_assert(static_cast<int>(CommandStatus::ok) == COBRIDGE_COMMAND_OK);
static_assert(static_cast<int>(CommandStatus::unknown_device) == COBRIDGE_COMMAND_UNKNOWN_DEVICE);
static_assert(static_cast<int>(CommandStatus::offline) == COBRIDGE_COMMAND_OFFLINE);
static_assert(static_cast<int>(CommandStatus::busy) == COBRIDGE_COMMAND_BUSY);
static_assert(static_cast<int>(CommandStatus::unsupported) == COBRIDGE_COMMAND_UNSUPPORTED);
static_assert(static_cast<int>(CommandStatus::invalid_value) == COBRIDGE_COMMAND_INVALID_VALUE);
static_assert(static_cast<int>(CommandStatus::refused) == COBRIDGE_COMMAND_REFUSED);
static_assert(static_cast<int>(CommandStatus::timeout) == COBRIDGE_COMMAND_TIMEOUT);
static_assert(static_cast<int>(CommandStatus::failed) == COBRIDGE_COMMAND_FAILED);

std::optional<CommandKind> command_kind(std::uint8_t raw) noexcept {
  switch (raw) {
    case COBRIDGE_COMMAND_PRESET: return CommandKind::preset;
    case COBRIDGE_COMMAND_NMT_RESET: return CommandKind::nmt_reset;
    case COBRIDGE_COMMAND_STORE: return CommandKind::store;
    default: return std::nullopt;
  }
}

const char* to_string(CommandKind kind) noexcept {
  switch (kind) {
    case CommandKind::preset: return "preset";
    case CommandKind::nmt_reset: return "NMT reset";
    case CommandKind::store: return "store";
  }
  return "?";
}

const char* to_string(CommandStatus status) noexcept {
  switch (status) {
    case CommandStatus::ok: return "done";
    case CommandStatus::unknown_device: return "unknown device";
    case CommandStatus::offline: return "device offline";
    case CommandStatus::busy: return "device busy";
    case CommandStatus::unsupported: return "not supported by the device";
    case CommandStatus::invalid_value: return "value out of range";
    case CommandStatus::refused: return "refused by the device";
    case CommandStatus::timeout: return "no answer from the device";
    case CommandStatus::failed: return "failed";
  }
  return "?";
}

}  // namespace cobridge::bus
