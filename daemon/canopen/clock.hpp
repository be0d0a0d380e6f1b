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

}  // namespace cobridge::canopen
