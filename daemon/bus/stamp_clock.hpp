// StampClock: when a received frame reached the socket, on the steady clock.
//
// SocketCAN stamps each frame with the kernel's receive time on
// CLOCK_REALTIME (SO_TIMESTAMPNS); every deadline of the control thread runs
// on the steady clock. The offset between the two is read rarely and only
// from a tight reading (wall, steady, wall with nothing between them): a
// thread preempted between two clock reads (each a system call under UML)
// would otherwise read an offset wrong by the preemption, and a heartbeat
// stamped that much early counts as a late one.
// Thread: the bus's control thread only.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>

#include "bus/bus_clock.hpp"

namespace cobridge::bus {

class StampClock {
 public:
  // A stamp further than this from the turn's clock is not trusted (the wall
  // clock stepped, or the offset is not known): the turn's clock stands in.
  static constexpr std::chrono::milliseconds kSkewLimit{1000};
  // A reading whose two wall reads lie further apart than this was
  // preempted: not used while an older offset is known.
  static constexpr std::chrono::microseconds kTightRead{1000};
  // The offset is read again this often (NTP slews it by at most 0.5 ms/s).
  static constexpr std::chrono::seconds kRefresh{1};
  // A stamp far off is taken for a stepped wall clock this often at most.
  static constexpr std::chrono::milliseconds kRecheck{100};

  explicit StampClock(const BusClock& clock) noexcept : clock_(clock) {}

  // The steady time of a frame stamped `stamp_ns` (ns since the epoch,
  // CLOCK_REALTIME); `now` (the turn's clock) for a frame without a stamp.
  [[nodiscard]] canopen::TimePoint arrival(std::int64_t stamp_ns, canopen::TimePoint now) noexcept;

 private:
  // Reads the offset; false when no reading was tight (the old one stays).
  bool read_offset(bool accept_loose) noexcept;
  [[nodiscard]] std::optional<canopen::TimePoint> convert(std::int64_t stamp_ns, canopen::TimePoint now) const noexcept;

  const BusClock& clock_;
  std::optional<std::chrono::nanoseconds> steady_minus_wall_;
  canopen::TimePoint read_at_{};
};

}  // namespace cobridge::bus
