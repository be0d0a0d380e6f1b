#include "command_desk.hpp"

#include <cstdio>

namespace cobridge::mqtt {
namespace {

std::string describe(const DcmdRequest& r, const char* name) {
  std::string what = command_name(r.kind);
  if (r.kind == COBRIDGE_COMMAND_PRESET) what += " to " + std::to_string(r.value);
  return what + " on device " + name;
}

std::string hex8(std::uint32_t v) {
  char buf[12];
  std::snprintf(buf, sizeof buf, "0x%08X", v);
  return buf;
}

}  // namespace

const char* command_status_text(int status) noexcept {
  switch (status) {
    case COBRIDGE_COMMAND_OK: return "done";
    case COBRIDGE_COMMAND_UNKNOWN_DEVICE: return "no configured device has this index";
    case COBRIDGE_COMMAND_OFFLINE: return "the device is offline";
    case COBRIDGE_COMMAND_BUSY: return "the device is busy (configuring or another command)";
    case COBRIDGE_COMMAND_UNSUPPORTED: return "the device does not support this command";
    case COBRIDGE_COMMAND_INVALID_VALUE: return "the value is outside the object's type or limits";
    case COBRIDGE_COMMAND_REFUSED: return "the device refused it (SDO abort)";
    case COBRIDGE_COMMAND_TIMEOUT: return "the device did not answer";
    default: return "failed";
  }
}

CommandDesk::CommandDesk(WritePolicy policy, Submit submit, LogFn log)
    : policy_(std::move(policy)), submit_(std::move(submit)), log_(std::move(log)) {}

CommandResult CommandDesk::refuse(const DcmdRequest& r, int device_index, std::int32_t code, const std::string& why) {
  log_(COBRIDGE_LOG_WARN, std::string("DCMD for device ") + r.device_id + " from client '" + r.client +
                              "' refused: " + why);
  return CommandResult{static_cast<std::uint16_t>(device_index < 0 ? 0 : device_index), r.client,
                       "refused: " + why, code};
}

std::optional<CommandResult> CommandDesk::on_dcmd(const DcmdRequest& r, int device_index, const char* name) {
  if (device_index < 0) {
    // No device to publish a result under: the log is the only answer.
    log_(COBRIDGE_LOG_WARN, std::string("DCMD for unknown device '") + r.device_id + "' from client '" + r.client +
                                "' ignored: no device of this edge node has that id");
    return std::nullopt;
  }
  if (r.kind == 0) return refuse(r, device_index, static_cast<std::int32_t>(CommandRefusal::kMalformed), r.error);
  if (r.alias_device >= 0 && r.alias_device != device_index)
    return refuse(r, device_index, static_cast<std::int32_t>(CommandRefusal::kMalformed),
                  "the metric's alias belongs to another device (index " + std::to_string(r.alias_device) + ")");
  const std::string why = policy_.refusal(name, r.kind);
  if (!why.empty())
    return refuse(r, device_index,
                  static_cast<std::int32_t>(policy_.enabled ? CommandRefusal::kNotAllowed
                                                            : CommandRefusal::kWritesDisabled),
                  why);
  if (!submit_) return refuse(r, device_index, static_cast<std::int32_t>(CommandRefusal::kNoCommands),
                              "this daemon takes no commands from plugins (plugin ABI < 2)");
  cobridge_command c{};
  c.struct_size = sizeof c;
  c.device_index = static_cast<std::uint16_t>(device_index);
  c.kind = r.kind;
  c.tag = kTagMark | ++next_tag_;
  c.value = r.value;
  const int status = submit_(c);
  if (status != COBRIDGE_COMMAND_OK) return refuse(r, device_index, status, command_status_text(status));
  Pending& p = pending_[next_slot_];
  next_slot_ = (next_slot_ + 1) % pending_.size();
  p = Pending{true, c.tag, c.device_index, r.client, describe(r, name)};
  log_(COBRIDGE_LOG_INFO, "DCMD from client '" + p.client + "': " + p.what + " submitted (tag " + hex8(c.tag) + ")");
  return std::nullopt;
}

std::optional<CommandResult> CommandDesk::on_sample(const cobridge_sample& s) {
  if (s.kind != COBRIDGE_SAMPLE_COMMAND || (s.valid & COBRIDGE_VALID_COMMAND) == 0) return std::nullopt;
  if ((s.command_tag & 0xFFFF0000u) != kTagMark) return std::nullopt;
  for (Pending& p : pending_) {
    if (!p.used || p.tag != s.command_tag || p.device_index != s.device_index) continue;
    p.used = false;
    std::string text = command_status_text(s.command_status);
    if (s.command_status == COBRIDGE_COMMAND_REFUSED) text += ", abort code " + hex8(s.command_abort_code);
    log_(s.command_status == COBRIDGE_COMMAND_OK ? COBRIDGE_LOG_INFO : COBRIDGE_LOG_WARN,
         "DCMD from client '" + p.client + "': " + p.what + ": " + text);
    return CommandResult{p.device_index, p.client, text, s.command_status};
  }
  return std::nullopt;
}

}  // namespace cobridge::mqtt
