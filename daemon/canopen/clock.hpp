// Time as the CANopen services see it.
//
// No service reads a clock: the caller passes `now` into every call, and every
// `process(now)` returns the next deadline at which it wants to be called again
// (kNever when it has nothing pending). Tests therefore run on a fake clock
// without sleeping.
#pragma once

#include <chrono>

namespace cobridge::canopen {

using Clock = std::chrono::steady_clock;
using TimePoint = Clock::time_point;
using Duration = Clock::duration;

inline constexpr TimePoint kNever = TimePoint::max();

// When a frame stamped by the kernel at `stamp_ns` (CLOCK_REALTIME, as
// SO_TIMESTAMPNS gives it) arrived, on this steady clock, given one reading
// of each clock (`now`, `realtime_now_ns`). Never after `now`; `now` for a
// frame without a stamp (or a realtime clock that stepped back meanwhile).
[[nodiscard]] inline TimePoint received_at(long long stamp_ns, TimePoint now, long long realtime_now_ns) noexcept {
  if (stamp_ns <= 0 || realtime_now_ns <= stamp_ns) return now;
  return now - std::chrono::duration_cast<Duration>(std::chrono::nanoseconds(realtime_now_ns - stamp_ns));
}

}  // namespace cobridge::canopen
