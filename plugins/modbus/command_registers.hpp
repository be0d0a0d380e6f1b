// CommandRegisters: the writable corner of the Modbus map and the way a
// write reaches a device (plugin ABI 2, cobridge_host_api.submit_command).
//
// Per device slot (offsets from the slot base, register_map.hpp):
//   +28..29 command_value   int32, RW: the argument (PRESET: the position);
//                           kept as written, word order as configured
//   +30     command         uint16, RW: writing 1 = preset, 2 = NMT reset,
//                           3 = store submits the command; reads the code
//                           last submitted
//   +31     command_status  uint16, R: 0 none, 1 pending, 2 done, else
//                           2 + enum cobridge_command_status of the refusal
//
// A write is all or nothing: every register it names must be one of
// +28..+30 of one slot, and the command code must be 1..3, or nothing
// changes and the answer is an exception (0x02 address, 0x03 value). A
// command for an empty slot or an offline device answers 0x0B, one while
// the previous command of the slot is pending answers 0x06 (for at most
// kPendingTimeout), one the daemon refuses at once answers 0x0B (unknown or
// offline device), 0x06 (busy) or 0x04. An accepted command is answered at
// once; its outcome shows in command_status when the daemon reports it.
//
// Thread contract: write() on the Modbus server thread only; on_sample() on
// the dispatcher thread; render() on any reader thread. The per-slot state
// is in atomics (tag, code and status in one word, so an outcome for an old
// command can never overwrite a newer one); no lock, no allocation.
#pragma once

#include "register_image.hpp"
#include "request.hpp"

#include <cobridge/plugin.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>

namespace cobridge::modbus {

// command_status register values.
inline constexpr std::uint16_t kCommandNone = 0;
inline constexpr std::uint16_t kCommandPending = 1;
inline constexpr std::uint16_t kCommandDone = 2;
// A refusal or failure: kCommandDone + enum cobridge_command_status (1..).
[[nodiscard]] constexpr std::uint16_t command_failure(int status) noexcept {
  return static_cast<std::uint16_t>(kCommandDone + status);
}

class CommandRegisters final : public WriteTarget {
 public:
  // Hands a command to the daemon; returns an enum cobridge_command_status.
  using Submit = std::function<int(const cobridge_command&)>;
  // A pending command blocks the next one of its slot at most this long
  // (in case its outcome is lost, e.g. the daemon restarted its bus).
  static constexpr std::uint64_t kPendingTimeoutNs = 10'000'000'000u;

  // `image` tells which slots hold a device and whether it is online.
  CommandRegisters(const RegisterImage& image, Submit submit);
  ~CommandRegisters() override;
  CommandRegisters(const CommandRegisters&) = delete;
  CommandRegisters& operator=(const CommandRegisters&) = delete;

  // Server thread: a validated write request (request.hpp), registers
  // [address, address + values.size()).
  [[nodiscard]] ExceptionCode write(std::uint16_t address, std::span<const std::uint16_t> values,
                                    ReadTime now) noexcept override;

  // Dispatcher thread: picks the outcome of this slot's pending command out
  // of a COMMAND sample; ignores everything else.
  void on_sample(const cobridge_sample& s) noexcept;

  // Any thread: registers +28..+31 of `slot` into block[28..31].
  void render(std::uint16_t slot, std::uint16_t* block) const noexcept;

  [[nodiscard]] std::uint64_t submitted() const noexcept { return submitted_.load(std::memory_order_relaxed); }

 private:
  struct alignas(64) Slot {
    std::atomic<std::uint16_t> value_regs[2] = {0, 0};  // +28, +29 as written
    std::atomic<std::uint64_t> state{0};  // tag << 32 | code << 16 | status
    std::uint64_t submitted_ns = 0;       // server thread only
  };
  ExceptionCode submit_command(Slot& s, std::uint16_t slot, std::uint16_t code, ReadTime now) noexcept;

  const RegisterImage& image_;
  Submit submit_;
  std::unique_ptr<Slot[]> slots_;
  std::uint16_t slot_count_;
  std::uint32_t next_tag_ = 0;  // server thread only
  std::atomic<std::uint64_t> submitted_{0};
};

}  // namespace cobridge::modbus
