// EmcyProducer: the emergency server of a simulated encoder (CiA 301 §7.2.7).
//
// Sends an EMCY on the COB-ID in 0x1014 (not if its bit 31 says "not
// valid"), records it in the pre-defined error field 0x1003 where the
// dictionary has one (ifm, F§7.3: newest in sub 1, at most 10), keeps the
// error register 0x1001, honours an inhibit time 0x1015 where present
// (frames inside it wait in a small queue) and applies the multiturn level
// filter 0x2104 (E§4.3: 1 = no Info, 2 = no Info/Warn, 3 = only Hard).
//
// The error register is the OR of the conditions the device says are active
// (`set_condition`), not of the bytes of the last frame: a CAM EMCY carries
// 1 in byte 2 as J§1.8.1 prints it, but a CAM change is not an error.
// Thread: the device's thread; send/process are noexcept, no allocation.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "can/frame.hpp"
#include "canopen/clock.hpp"
#include "canopen/emcy.hpp"
#include "canopen/object_dictionary.hpp"
#include "families/emcy_table.hpp"

namespace cobridge::sim {

using canopen::TimePoint;

class EmcyProducer {
 public:
  // `send` puts the frame on the bus (the device's transmit path).
  using SendFn = bool (*)(void* context, const can::Frame& frame) noexcept;

  void attach(canopen::ObjectDictionary* od, SendFn send_fn, void* context) noexcept;

  // Filtered by level (0x2104), queued behind the inhibit time (0x1015).
  // Returns false when filtered or dropped.
  bool send(const canopen::Emcy& emcy, families::EmcyLevel level, TimePoint now) noexcept;
  [[nodiscard]] TimePoint process(TimePoint now) noexcept;
  void reset() noexcept;

  // The error register bits that are currently active (OR of conditions).
  void set_error_register(std::uint8_t bits) noexcept;
  [[nodiscard]] std::uint8_t error_register() const noexcept { return register_; }

 private:
  static constexpr std::size_t kQueue = 8;
  bool transmit(const canopen::Emcy& emcy, TimePoint now) noexcept;
  void record_history(const canopen::Emcy& emcy) noexcept;

  canopen::ObjectDictionary* od_ = nullptr;
  SendFn send_ = nullptr;
  void* context_ = nullptr;
  std::uint8_t register_ = 0;
  std::array<canopen::Emcy, kQueue> queue_{};
  std::size_t queued_ = 0;
  bool have_sent_ = false;
  TimePoint last_sent_{};
};

}  // namespace cobridge::sim
