#include "command_registers.hpp"

namespace cobridge::modbus {
namespace {

constexpr std::uint16_t kValueOffset = 28;
constexpr std::uint16_t kCommandOffset = 30;
constexpr std::uint16_t kStatusOffset = 31;

constexpr std::uint64_t pack(std::uint32_t tag, std::uint16_t code, std::uint16_t status) noexcept {
  return (static_cast<std::uint64_t>(tag) << 32) | (static_cast<std::uint64_t>(code) << 16) | status;
}
constexpr std::uint32_t tag_of(std::uint64_t s) noexcept { return static_cast<std::uint32_t>(s >> 32); }
constexpr std::uint16_t code_of(std::uint64_t s) noexcept { return static_cast<std::uint16_t>((s >> 16) & 0xFFFFu); }
constexpr std::uint16_t status_of(std::uint64_t s) noexcept { return static_cast<std::uint16_t>(s & 0xFFFFu); }

bool known_command(std::uint16_t code) noexcept {
  return code == COBRIDGE_COMMAND_PRESET || code == COBRIDGE_COMMAND_NMT_RESET || code == COBRIDGE_COMMAND_STORE;
}

// The Modbus answer to a command the daemon refused at once.
ExceptionCode refusal_exception(int status) noexcept {
  switch (status) {
    case COBRIDGE_COMMAND_UNKNOWN_DEVICE:
    case COBRIDGE_COMMAND_OFFLINE: return ExceptionCode::kGatewayTargetFailed;
    case COBRIDGE_COMMAND_BUSY: return ExceptionCode::kServerDeviceBusy;
    default: return ExceptionCode::kServerDeviceFailure;
  }
}

}  // namespace

CommandRegisters::CommandRegisters(const RegisterImage& image, Submit submit)
    : image_(image),
      submit_(std::move(submit)),
      slots_(std::make_unique<Slot[]>(image.options().device_slots)),
      slot_count_(image.options().device_slots) {}

CommandRegisters::~CommandRegisters() = default;

ExceptionCode CommandRegisters::write(std::uint16_t address, std::span<const std::uint16_t> values,
                                      ReadTime now) noexcept {
  if (values.empty() || address < kDeviceBase) return ExceptionCode::kIllegalDataAddress;
  const auto slot = static_cast<std::uint16_t>((address - kDeviceBase) / kDeviceStride);
  const auto first = static_cast<std::uint16_t>((address - kDeviceBase) % kDeviceStride);
  const auto last = static_cast<std::uint32_t>(first + values.size() - 1u);
  // Only +28..+30 of one slot are writable.
  if (slot >= slot_count_ || first < kValueOffset || last > kCommandOffset) return ExceptionCode::kIllegalDataAddress;

  const bool has_command = last >= kCommandOffset;
  const std::uint16_t code = has_command ? values[kCommandOffset - first] : 0;
  if (has_command && !known_command(code)) return ExceptionCode::kIllegalDataValue;

  DeviceState device;
  if (!image_.snapshot(slot, device)) return ExceptionCode::kServerDeviceFailure;
  if (device.present == 0) return ExceptionCode::kGatewayTargetFailed;
  Slot& s = slots_[slot];
  if (has_command) {
    if (device.online == 0) return ExceptionCode::kGatewayTargetFailed;
    const std::uint64_t st = s.state.load(std::memory_order_acquire);
    if (status_of(st) == kCommandPending && now.monotonic_ns - s.submitted_ns < kPendingTimeoutNs) {
      return ExceptionCode::kServerDeviceBusy;
    }
  }
  for (std::uint32_t r = first; r <= last && r < kCommandOffset; ++r) {
    s.value_regs[r - kValueOffset].store(values[r - first], std::memory_order_relaxed);
  }
  if (!has_command) return ExceptionCode::kNone;

  return submit_command(s, slot, code, now);
}

// Marks the slot pending and hands the command to the daemon; a refusal is
// the slot's outcome at once.
ExceptionCode CommandRegisters::submit_command(Slot& s, std::uint16_t slot, std::uint16_t code, ReadTime now) noexcept {
  // The argument as the client wrote it, in the configured word order.
  const std::uint16_t a = s.value_regs[0].load(std::memory_order_relaxed);
  const std::uint16_t b = s.value_regs[1].load(std::memory_order_relaxed);
  const bool big = image_.options().word_order == WordOrder::kBig;
  const std::uint32_t bits = big ? (static_cast<std::uint32_t>(a) << 16) | b : (static_cast<std::uint32_t>(b) << 16) | a;

  cobridge_command cmd{};
  cmd.struct_size = sizeof cmd;
  cmd.device_index = slot;
  cmd.kind = static_cast<std::uint8_t>(code);
  cmd.tag = ++next_tag_;
  cmd.value = code == COBRIDGE_COMMAND_PRESET ? static_cast<std::int32_t>(bits) : 0;
  // Pending before the daemon sees it: its outcome may come back at once.
  s.submitted_ns = now.monotonic_ns;
  s.state.store(pack(cmd.tag, code, kCommandPending), std::memory_order_release);
  int rc = COBRIDGE_COMMAND_UNSUPPORTED;
  if (submit_) {
    try {
      rc = submit_(cmd);
    } catch (...) {
      rc = COBRIDGE_COMMAND_FAILED;
    }
  }
  submitted_.fetch_add(1, std::memory_order_relaxed);
  if (rc == COBRIDGE_COMMAND_OK) return ExceptionCode::kNone;
  // Refused now: no outcome will follow. Only this thread writes a pending
  // slot's tag, so the CAS fails only if the outcome raced in (it cannot
  // for a refusal; kept for safety).
  std::uint64_t expected = pack(cmd.tag, code, kCommandPending);
  const auto failure = command_failure(rc > 0 && rc <= 0xFF ? rc : COBRIDGE_COMMAND_FAILED);
  s.state.compare_exchange_strong(expected, pack(cmd.tag, code, failure), std::memory_order_acq_rel);
  return refusal_exception(rc);
}

void CommandRegisters::on_sample(const cobridge_sample& s) noexcept {
  if (s.kind != COBRIDGE_SAMPLE_COMMAND || (s.valid & COBRIDGE_VALID_COMMAND) == 0 || s.device_index >= slot_count_) {
    return;
  }
  Slot& slot = slots_[s.device_index];
  std::uint64_t expected = slot.state.load(std::memory_order_acquire);
  if (tag_of(expected) != s.command_tag || status_of(expected) != kCommandPending) return;  // not ours, or old
  const std::uint16_t status = s.command_status == COBRIDGE_COMMAND_OK ? kCommandDone : command_failure(s.command_status);
  slot.state.compare_exchange_strong(expected, pack(s.command_tag, code_of(expected), status),
                                     std::memory_order_acq_rel);
}

void CommandRegisters::render(std::uint16_t slot, std::uint16_t* block) const noexcept {
  if (slot >= slot_count_) return;
  const Slot& s = slots_[slot];
  block[kValueOffset] = s.value_regs[0].load(std::memory_order_relaxed);
  block[kValueOffset + 1] = s.value_regs[1].load(std::memory_order_relaxed);
  const std::uint64_t st = s.state.load(std::memory_order_acquire);
  block[kCommandOffset] = code_of(st);
  block[kStatusOffset] = status_of(st);
}

}  // namespace cobridge::modbus
