// Work-area state 0x6400: J§1.4.6.1, E§5.7.1, F§7.5 0x6400..0x6402, F§7.5 0x6400, E§5.7.1.
#include "encoder/work_area.hpp"

#include <gtest/gtest.h>

namespace cobridge::sim {
namespace {

// E§5.7.1: bit 2 pos < low, bit 1 pos > high, bit 0 pos <= min or >= max of 0x650A (inclusive).
TEST(WorkArea, E_5_7_1_StateBits) {
  const WorkAreaLimits l{100, 1000, 0, 0x2BFFFF};
  const auto r = WorkAreaRule::multiturn;
  EXPECT_EQ(work_area_state(r, l, 50), kWorkAreaUnderflow);
  EXPECT_EQ(work_area_state(r, l, 100), 0);
  EXPECT_EQ(work_area_state(r, l, 1000), 0);
  EXPECT_EQ(work_area_state(r, l, 1001), kWorkAreaOverflow);
  EXPECT_EQ(work_area_state(r, l, 0), kWorkAreaUnderflow | kWorkAreaOutOfRange);
  EXPECT_EQ(work_area_state(r, l, 0x2BFFFF), kWorkAreaOverflow | kWorkAreaOutOfRange);
  EXPECT_EQ(work_area_state(r, l, 0x2BFFFE), kWorkAreaOverflow);
}

// J§1.4.6.1 prints bit 1 = "pos < high"; erratum (J§1.4.6.1, E§5.3): pos > high.
// Bit 0 as printed: pos <= preset or pos >= sensor length.
TEST(WorkArea, J_1_4_6_1_OverflowErratumAndOutOfRange) {
  const WorkAreaLimits l{0, 0x3FFF, 0 /*preset*/, 0x4000 /*sensor length*/};
  const auto r = WorkAreaRule::rotary;
  EXPECT_EQ(work_area_state(r, l, 500) & kWorkAreaOverflow, 0);  // not "pos < high"
  EXPECT_EQ(work_area_state(r, l, 500), 0);
  EXPECT_EQ(work_area_state(r, l, 0), kWorkAreaOutOfRange);  // "<= preset" as printed (erratum A.9.16)
  WorkAreaLimits narrow{1000, 2000, 0, 0x4000};
  EXPECT_EQ(work_area_state(r, narrow, 2001), kWorkAreaOverflow);
  EXPECT_EQ(work_area_state(r, narrow, 999), kWorkAreaUnderflow);
}

// F§7.5 0x6401/0x6402 descriptions (the 0x6400 table swaps them, F§7.5 0x6400);
// bit 0: outside 0x650A/2..3, bounds themselves in range.
TEST(WorkArea, F_7_5_DescriptionsWinOverSwappedTable) {
  const WorkAreaLimits l{100, 1000, 0, 0xFFFFFF};
  const auto r = WorkAreaRule::ifm;
  EXPECT_EQ(work_area_state(r, l, 99), kWorkAreaUnderflow);
  EXPECT_EQ(work_area_state(r, l, 1001), kWorkAreaOverflow);
  EXPECT_EQ(work_area_state(r, l, 500), 0);
  const WorkAreaLimits wide{-10, 0x1000000, 0, 0xFFFFFF};
  EXPECT_EQ(work_area_state(r, wide, 0), 0);
  EXPECT_EQ(work_area_state(r, wide, 0xFFFFFF), 0);
  EXPECT_EQ(work_area_state(r, wide, -1), kWorkAreaOutOfRange);
}

// J§1.4.6, E§5.7: a change of state -> EMCY 0x9090; the register starts at 0.
TEST(WorkArea, E_5_7_ChangeDetection) {
  WorkArea wa(WorkAreaRule::multiturn, {100, 1000, 0, 0x2BFFFF});
  auto u = wa.evaluate(500);
  EXPECT_FALSE(u.changed);
  u = wa.evaluate(50);
  EXPECT_TRUE(u.changed);
  EXPECT_EQ(u.state, kWorkAreaUnderflow);
  EXPECT_FALSE(wa.evaluate(60).changed);
  wa.limits().low = 10;
  u = wa.evaluate(60);
  EXPECT_TRUE(u.changed);
  EXPECT_EQ(wa.state(), 0);
}

// E§9.1 0x9090 byte 7: 0x6400 value by default, enumeration 0/1/2 as a switch (E§9.1).
TEST(WorkArea, E_9_1_EmcyStateCoding) {
  EXPECT_EQ(work_area_emcy_state(kWorkAreaUnderflow, WorkAreaEmcyCoding::state_bits), 0x04);
  EXPECT_EQ(work_area_emcy_state(kWorkAreaUnderflow | kWorkAreaOutOfRange, WorkAreaEmcyCoding::state_bits), 0x05);
  EXPECT_EQ(work_area_emcy_state(kWorkAreaUnderflow, WorkAreaEmcyCoding::enumeration), 1);
  EXPECT_EQ(work_area_emcy_state(kWorkAreaOverflow | kWorkAreaOutOfRange, WorkAreaEmcyCoding::enumeration), 2);
  EXPECT_EQ(work_area_emcy_state(kWorkAreaOutOfRange, WorkAreaEmcyCoding::enumeration), 0);
  EXPECT_EQ(work_area_emcy_state(0, WorkAreaEmcyCoding::enumeration), 0);
}

}  // namespace
}  // namespace cobridge::sim
