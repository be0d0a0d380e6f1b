// canopen::received_at: a frame's kernel stamp (SO_TIMESTAMPNS, realtime)
// on the steady clock the services run on (LssMaster::on_frame's `arrived`).
#include "canopen/clock.hpp"

#include <gtest/gtest.h>

namespace cobridge::canopen {
namespace {

using namespace std::chrono_literals;

constexpr long long kRealtimeNow = 1'790'000'000'000'000'000LL;  // ns since the epoch

TEST(ClockTest, AStampedFrameArrivedItsAgeBeforeNow) {
  const TimePoint now = TimePoint{} + 1h;
  EXPECT_EQ(received_at(kRealtimeNow - 2'500'000, now, kRealtimeNow), now - 2500us);
}

TEST(ClockTest, WithoutAStampOrAStampFromTheFutureItIsNow) {
  const TimePoint now = TimePoint{} + 1h;
  EXPECT_EQ(received_at(0, now, kRealtimeNow), now);
  // The realtime clock stepped back between the stamp and the reading.
  EXPECT_EQ(received_at(kRealtimeNow + 1'000'000, now, kRealtimeNow), now);
}

}  // namespace
}  // namespace cobridge::canopen
