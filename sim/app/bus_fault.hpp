// Bus-level faults cobridge-sim can put on a bus: Linux CAN error frames
// (what a real controller reports when the bus turns error-passive or
// bus-off, <linux/can/error.h>), a bus flood (frames of the highest priority,
// identifier 0, back to back) and a babbling node (one identifier, back to
// back). On vcan the error frames reach every socket that subscribed to
// them (CAN_RAW_ERR_FILTER), which is how a gateway on vcan sees a bus state
// change that vcan itself can never have.
// Thread: the simulator's bus thread; TrafficGenerator does not allocate.
#pragma once

#include "can/frame.hpp"
#include "canopen/clock.hpp"

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

namespace cobridge::sim {

enum class BusErrorKind : std::uint8_t {
  error_warning,  // CAN_ERR_CRTL, RX/TX warning, counters 96
  error_passive,  // CAN_ERR_CRTL, RX/TX passive, counters 128
  error_active,   // CAN_ERR_CRTL, back to error-active
  bus_off,        // CAN_ERR_BUSOFF
  restarted,      // CAN_ERR_RESTARTED (controller restarted after bus-off)
};

[[nodiscard]] std::optional<BusErrorKind> parse_bus_error_kind(std::string_view text) noexcept;
[[nodiscard]] std::string_view to_string(BusErrorKind kind) noexcept;
// The error frame (Frame::kFlagError, class bits in id, 8 data bytes) a Linux
// CAN driver sends for `kind`.
[[nodiscard]] can::Frame make_error_frame(BusErrorKind kind) noexcept;

// Flood or babble on one bus for a while. The owner asks for a burst of
// frames whenever it loops; the burst is bounded so the devices keep running.
class TrafficGenerator {
 public:
  static constexpr std::uint32_t kFloodId = 0x000;  // highest priority; DLC 0 so no NMT parser acts on it

  void start_flood(canopen::TimePoint now, canopen::Duration duration) noexcept;
  void start_babble(std::uint32_t cob_id, canopen::TimePoint now, canopen::Duration duration) noexcept;
  void stop() noexcept { until_ = canopen::TimePoint{}; }

  [[nodiscard]] bool active(canopen::TimePoint now) const noexcept { return now < until_; }
  [[nodiscard]] bool flooding(canopen::TimePoint now) const noexcept { return active(now) && flood_; }
  // Fills `out` with the frames to send now (all of it while active).
  [[nodiscard]] std::size_t burst(canopen::TimePoint now, std::span<can::Frame> out) noexcept;
  // `now` while active (send again at once), kNever otherwise.
  [[nodiscard]] canopen::TimePoint process(canopen::TimePoint now) const noexcept {
    return active(now) ? now : canopen::kNever;
  }
  [[nodiscard]] std::uint64_t frames_generated() const noexcept { return generated_; }

 private:
  canopen::TimePoint until_{};
  bool flood_ = false;
  std::uint32_t cob_id_ = 0;
  std::uint64_t counter_ = 0;
  std::uint64_t generated_ = 0;
};

}  // namespace cobridge::sim
