// StampClock: a kernel receive stamp (CLOCK_REALTIME) on the steady clock,
// with an offset no preemption between two clock reads can skew
// (docs/reliability.md "A heartbeat read late"; CiA 302-2 flying master
// and CiA 301 §7.2.8.3.2.2 heartbeat consumer judge on these times).
#include "bus/stamp_clock.hpp"

#include <gtest/gtest.h>

#include <deque>

namespace cobridge::bus {
namespace {

using namespace std::chrono_literals;
using canopen::TimePoint;

// Real time moves only when a read is preempted (the next delay in line)
// or the test advances it; the wall clock runs `wall_ahead` ahead of the
// steady one.
class PreemptedClock final : public BusClock {
 public:
  TimePoint now() const noexcept override { return TimePoint{} + 1000s + take(); }
  WallTime wall() const noexcept override {
    const auto t = take();
    return WallTime{} + std::chrono::duration_cast<WallTime::duration>(1'800'000'000s + wall_ahead + 1000s + t);
  }
  // The next reads of either clock find `d` more time passed (a preemption
  // just before it).
  void preempt_next_read(std::chrono::nanoseconds d) { delays.push_back(d); }
  void advance(std::chrono::nanoseconds d) { elapsed += d; }
  // A frame received now, as the kernel stamps it.
  [[nodiscard]] std::int64_t stamp_now() const {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(1'800'000'000s + wall_ahead + 1000s + elapsed).count();
  }
  [[nodiscard]] TimePoint steady_now() const { return TimePoint{} + 1000s + elapsed; }

  std::chrono::nanoseconds wall_ahead{0};

 private:
  std::chrono::nanoseconds take() const {
    if (!delays.empty()) {
      elapsed += delays.front();
      delays.pop_front();
    }
    return elapsed;
  }
  mutable std::deque<std::chrono::nanoseconds> delays;
  mutable std::chrono::nanoseconds elapsed{0};
};

// A frame received at this moment and converted at once: how far its
// arrival lies from the moment (0 when the offset is right).
std::chrono::nanoseconds error_now(StampClock& s, const PreemptedClock& c) {
  const std::int64_t stamp = c.stamp_now();
  const TimePoint at = c.steady_now();
  return s.arrival(stamp, at) - at;
}

TEST(StampClock, AFrameWithoutAStampArrivesAtTheTurnsClock) {
  PreemptedClock c;
  StampClock s(c);
  EXPECT_EQ(s.arrival(0, c.steady_now()), c.steady_now());
}

TEST(StampClock, AStampIsTheSteadyTimeOfItsArrival) {
  PreemptedClock c;
  StampClock s(c);
  const std::int64_t stamp = c.stamp_now();
  const TimePoint at = c.steady_now();
  c.advance(60ms);  // read late
  EXPECT_EQ(s.arrival(stamp, c.steady_now()), at);
}

// The case that made a standby ask for a negotiation: the thread preempted
// for 100 ms between two clock reads of the offset. A reading whose wall
// reads lie 100 ms apart is not used; the next, tight one is.
TEST(StampClock, APreemptionBetweenTheOffsetsReadsDoesNotMoveTheStamp) {
  PreemptedClock c;
  StampClock s(c);
  const std::int64_t stamp = c.stamp_now();
  const TimePoint at = c.steady_now();
  c.preempt_next_read(0ns);     // wall
  c.preempt_next_read(100ms);   // steady, 100 ms later
  const TimePoint got = s.arrival(stamp, c.steady_now());
  EXPECT_LE(std::chrono::abs(got - at), StampClock::kTightRead) << "off by "
      << std::chrono::duration_cast<std::chrono::microseconds>(got - at).count() << " us";
}

// Every reading preempted, none known before: the loose one is used (its
// error at most half the preemption), rather than no stamp at all.
TEST(StampClock, OnlyLooseReadingsGiveAnOffsetWithinHalfThePreemption) {
  PreemptedClock c;
  StampClock s(c);
  const std::int64_t stamp = c.stamp_now();
  const TimePoint at = c.steady_now();
  for (int i = 0; i < 3; ++i) {
    c.preempt_next_read(0ns);
    c.preempt_next_read(0ns);
    c.preempt_next_read(4ms);  // the second wall read, 4 ms on
  }
  const TimePoint got = s.arrival(stamp, c.steady_now());
  EXPECT_LE(std::chrono::abs(got - at), 2ms);
}

// A known offset is not replaced by a loose reading at the refresh.
TEST(StampClock, ALooseRefreshKeepsTheKnownOffset) {
  PreemptedClock c;
  StampClock s(c);
  ASSERT_EQ(error_now(s, c), 0ns);  // the offset read
  c.advance(StampClock::kRefresh);
  for (int i = 0; i < 3; ++i) {
    c.preempt_next_read(0ns);
    c.preempt_next_read(80ms);
    c.preempt_next_read(0ns);
  }
  EXPECT_EQ(error_now(s, c), 0ns);
}

// NTP stepped the wall clock 5 s forward: the offset is read again and the
// stamps taken after the step are right again.
TEST(StampClock, AWallClockStepIsFollowed) {
  PreemptedClock c;
  StampClock s(c);
  ASSERT_EQ(error_now(s, c), 0ns);  // the offset read
  c.advance(200ms);
  c.wall_ahead = 5s;
  EXPECT_EQ(error_now(s, c), 0ns);
}

// A stamp from before a step, converted after the offset followed the
// step: 5 s off, not trusted; the turn's clock.
TEST(StampClock, AStampFarFromTheTurnsClockIsNotTrusted) {
  PreemptedClock c;
  StampClock s(c);
  ASSERT_EQ(error_now(s, c), 0ns);  // the offset read
  const std::int64_t before_step = c.stamp_now();
  c.advance(200ms);
  c.wall_ahead = -5s;
  EXPECT_EQ(s.arrival(c.stamp_now(), c.steady_now()), c.steady_now()) << "the step followed";
  const TimePoint now = c.steady_now();
  EXPECT_EQ(s.arrival(before_step, now), now);
}

}  // namespace
}  // namespace cobridge::bus
