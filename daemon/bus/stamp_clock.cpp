#include "bus/stamp_clock.hpp"

namespace cobridge::bus {

namespace {

using std::chrono::nanoseconds;

nanoseconds since_epoch(WallTime t) noexcept { return std::chrono::duration_cast<nanoseconds>(t.time_since_epoch()); }
nanoseconds since_epoch(canopen::TimePoint t) noexcept {
  return std::chrono::duration_cast<nanoseconds>(t.time_since_epoch());
}

}  // namespace

bool StampClock::read_offset(bool accept_loose) noexcept {
  constexpr int kTries = 3;
  for (int i = 0; i < kTries; ++i) {
    const nanoseconds w1 = since_epoch(clock_.wall());
    const canopen::TimePoint s = clock_.now();
    const nanoseconds w2 = since_epoch(clock_.wall());
    const bool tight = w2 - w1 <= kTightRead;
    if (tight || (accept_loose && i == kTries - 1)) {
      steady_minus_wall_ = since_epoch(s) - (w1 + (w2 - w1) / 2);
      read_at_ = s;
      return tight;
    }
  }
  read_at_ = clock_.now();  // asked again after kRefresh, not every frame
  return false;
}

std::optional<canopen::TimePoint> StampClock::convert(std::int64_t stamp_ns, canopen::TimePoint now) const noexcept {
  if (!steady_minus_wall_) return std::nullopt;
  const canopen::TimePoint at{std::chrono::duration_cast<canopen::Duration>(nanoseconds(stamp_ns) + *steady_minus_wall_)};
  if (at > now + kSkewLimit || at < now - kSkewLimit) return std::nullopt;
  return at;
}

canopen::TimePoint StampClock::arrival(std::int64_t stamp_ns, canopen::TimePoint now) noexcept {
  if (stamp_ns == 0) return now;  // a port that stamps nothing
  if (!steady_minus_wall_ || now - read_at_ >= kRefresh) (void)read_offset(!steady_minus_wall_);
  if (const auto at = convert(stamp_ns, now)) return *at;
  // Far off: the wall clock stepped since the offset was read (or the frame
  // waited that long). Read it again, at most every kRecheck.
  if (now - read_at_ < kRecheck) return now;
  (void)read_offset(true);
  return convert(stamp_ns, now).value_or(now);
}

}  // namespace cobridge::bus
