// AnswerTiming ("timeouts from the bus, not a constant"): waits
// learnt from measured LSS answer times, bounded by the configured floor and
// ceiling (CiA 305 fixes no response time).
#include "canopen/answer_timing.hpp"

#include <gtest/gtest.h>

namespace cobridge::canopen {
namespace {

using namespace std::chrono_literals;

TEST(AnswerTiming, CiA305_FullTimeoutUntilSomethingWasMeasured) {
  AnswerTiming t(5ms, 100ms);
  EXPECT_TRUE(t.learning());
  EXPECT_EQ(t.no_answer_wait(), 100ms);
  t.record(2ms);
  EXPECT_EQ(t.no_answer_wait(), 9ms);  // 4 x 2 ms + 1 ms
  EXPECT_EQ(t.settle(), 2ms);
}

TEST(AnswerTiming, CiA305_BoundedByFloorAndCeiling) {
  AnswerTiming t(10ms, 100ms);
  t.record(100us);
  EXPECT_EQ(t.no_answer_wait(), 10ms) << "never below the floor";
  t.record(40ms);
  EXPECT_EQ(t.no_answer_wait(), 100ms) << "never above the ceiling";
  t.record(250ms);  // beyond the ceiling: an answer to an older request, not a sample
  EXPECT_EQ(t.slowest(), 40ms);
  EXPECT_EQ(t.answers(), 2u);
}

// One late answer (a descheduled slave or gateway) raises the waits at once,
// and is forgotten within a few dozen ordinary answers rather than slowing
// every later step of the bus.
TEST(AnswerTiming, CiA305_AnOutlierIsForgotten) {
  AnswerTiming t(2ms, 100ms);
  t.record(1ms);
  t.record(30ms);
  EXPECT_EQ(t.slowest(), 30ms);
  EXPECT_EQ(t.no_answer_wait(), 100ms);
  for (int i = 0; i < 64; ++i) t.record(1ms);
  EXPECT_LT(t.slowest(), 3ms);
  EXPECT_GE(t.slowest(), 1ms);
  EXPECT_LT(t.no_answer_wait(), 13ms);
}

TEST(AnswerTiming, CiA305_FixedWhenFloorEqualsCeiling) {
  AnswerTiming t(100ms, 100ms);
  t.record(1ms);
  EXPECT_FALSE(t.learning());
  EXPECT_EQ(t.no_answer_wait(), 100ms);
  EXPECT_EQ(t.settle(), 100ms);
}

}  // namespace
}  // namespace cobridge::canopen
