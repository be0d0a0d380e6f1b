// CAM evaluation: J§1.4.5, E§5.6, F§7.5 0x6300..0x6337, F§7.5, E§5.6.
#include "encoder/cam.hpp"

#include <gtest/gtest.h>

namespace cobridge::sim {
namespace {

CamBank one_cam(std::int64_t low, std::int64_t high, std::int64_t hyst = 0) {
  CamBank b(4);
  b.set_limits(0, {low, high, hyst});
  b.set_enable_mask(0x01);
  return b;
}

// J§1.4.5, E§5.6: active while the position is between low and high (inclusive).
TEST(CamBank, J_1_4_5_WindowInclusive) {
  auto b = one_cam(100, 200);
  EXPECT_EQ(b.evaluate(99).state, 0);
  auto u = b.evaluate(100);
  EXPECT_EQ(u.state, 0x01);
  EXPECT_EQ(u.changed, 0x01);
  u = b.evaluate(200);
  EXPECT_EQ(u.state, 0x01);
  EXPECT_EQ(u.changed, 0x00);
  u = b.evaluate(201);
  EXPECT_EQ(u.state, 0x00);
  EXPECT_EQ(u.changed, 0x01);
}

// J§1.3.2 0x6302, E§4.2: polarity bit 1 signals an active CAM with state bit 0.
TEST(CamBank, J_1_3_2_PolarityInverts) {
  auto b = one_cam(100, 200);
  b.set_polarity_mask(0x01);
  EXPECT_EQ(b.evaluate(150).state, 0x00);
  EXPECT_EQ(b.evaluate(250).state, 0x01);
}

// J§1.3.2 0x6301: a disabled CAM is permanently 0, whatever the polarity (J§1.4.5).
TEST(CamBank, J_1_3_2_DisabledReadsZeroWhateverPolarity) {
  auto b = one_cam(100, 200);
  b.set_enable_mask(0x00);
  b.set_polarity_mask(0x01);
  EXPECT_EQ(b.evaluate(150).state, 0x00);
  EXPECT_EQ(b.evaluate(250).state, 0x00);
  EXPECT_EQ(b.active_mask(), 0x00);
  b.set_enable_mask(0x01);  // enabling shows the state at once
  const auto u = b.evaluate(250);
  EXPECT_EQ(u.state, 0x01);
  EXPECT_EQ(u.changed, 0x01);
}

// J§1.4.5 note / E§5.6 note: high may be lower than low -> wrap-around window.
TEST(CamBank, J_1_4_5_HighBelowLowWraps) {
  auto b = one_cam(300, 100);
  EXPECT_EQ(b.evaluate(350).state, 0x01);
  EXPECT_EQ(b.evaluate(300).state, 0x01);
  EXPECT_EQ(b.evaluate(200).state, 0x00);
  EXPECT_EQ(b.evaluate(100).state, 0x01);
  EXPECT_EQ(b.evaluate(50).state, 0x01);
  EXPECT_EQ(b.evaluate(299).state, 0x00);
}

// J§1.4.5, E§5.6 hysteresis "added in the direction of motion", read literally
// reading: moving up the switch points are limit + h, moving down limit - h.
TEST(CamBank, J1_4_5_HysteresisInDirectionOfMotion) {
  auto b = one_cam(100, 200, 10);
  EXPECT_EQ(b.evaluate(50).state, 0);
  EXPECT_EQ(b.evaluate(105).state, 0);  // up: on at 110
  EXPECT_EQ(b.evaluate(110).state, 1);
  EXPECT_EQ(b.evaluate(205).state, 1);  // up: off beyond 210
  EXPECT_EQ(b.evaluate(210).state, 1);
  EXPECT_EQ(b.evaluate(211).state, 0);
  EXPECT_EQ(b.evaluate(195).state, 0);  // down: on at 190
  EXPECT_EQ(b.evaluate(190).state, 1);
  EXPECT_EQ(b.evaluate(95).state, 1);   // down: off below 90
  EXPECT_EQ(b.evaluate(90).state, 1);
  EXPECT_EQ(b.evaluate(89).state, 0);
}

// J§1.4.5: at standstill the state holds; reversing inside the band does not toggle.
TEST(CamBank, J1_4_5_StandstillAndReversalHold) {
  auto b = one_cam(100, 200, 10);
  b.evaluate(150);
  EXPECT_EQ(b.evaluate(95).state, 1);  // inside the low band coming down: still on
  EXPECT_EQ(b.evaluate(95).state, 1);  // standstill
  EXPECT_EQ(b.evaluate(105).state, 1);
  b.evaluate(250);
  EXPECT_EQ(b.evaluate(205).state, 0);  // coming down into the high band: still off
  EXPECT_EQ(b.evaluate(208).state, 0);  // reversing up inside the band
  EXPECT_EQ(b.evaluate(208).state, 0);
}

// J§1.8.1, E§9.1 0x9080: the changed mask names exactly the CAMs that changed.
TEST(CamBank, E_9_1_ChangedMaskForEmcy) {
  CamBank b(4);
  b.set_limits(0, {0, 100, 0});
  b.set_limits(1, {50, 150, 0});
  b.set_limits(2, {200, 300, 0});
  b.set_limits(3, {0, 1000, 0});
  b.set_enable_mask(0x0F);
  auto u = b.evaluate(10);
  EXPECT_EQ(u.state, 0x09);
  EXPECT_EQ(u.changed, 0x09);
  u = b.evaluate(120);
  EXPECT_EQ(u.state, 0x0A);
  EXPECT_EQ(u.changed, 0x03);
  u = b.evaluate(120);
  EXPECT_FALSE(u.any_change());
}

// F§7.5 0x6300 "cams 1 to 8": eight CAMs on one channel; CAM8 is bit 7.
TEST(CamBank, F_7_5_EightCams) {
  CamBank b(8);
  EXPECT_EQ(b.size(), 8U);
  b.set_limits(7, {1000, 2000, 0});
  b.set_enable_mask(0xFF);
  b.set_polarity_mask(0x7F);  // CAMs 1..7 inactive -> read 1
  EXPECT_EQ(b.evaluate(1500).state, 0xFF);
  EXPECT_EQ(b.active_mask(), 0x80);
  EXPECT_EQ(b.evaluate(2500).state, 0x7F);
}

}  // namespace
}  // namespace cobridge::sim
