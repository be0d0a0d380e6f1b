// SimDevice and the shaft: moving it by hand (control `move`) and the speed
// range limit of the multiturn (E§10.1 bit 19, E§10.3 bit 6).
#include "sim_bench.hpp"

namespace cobridge::sim::test {
namespace {

// The position (channel 1) of the TPDO1 frames sent from `from` on, as the
// truth records decode them.
std::vector<std::int64_t> tpdo_positions(const Bench& b, std::size_t from) {
  std::vector<std::int64_t> out;
  for (std::size_t i = from; i < b.truth.size(); ++i)
    if (b.truth[i].kind == TruthRecord::Kind::tpdo && b.truth[i].pdo == 1 && b.truth[i].has_position)
      out.push_back(b.truth[i].position);
  return out;
}

// J§1.2.3 (14 bit = 16384 counts per turn), J§1.3.1 0x1800/5: a quarter turn
// by hand shows as +4096 counts in the very next TPDO1; half a turn back
// wraps through 0 (the rotary counts modulo one turn).
TEST(SimDeviceMove, RotaryPositionJumpsInNextTpdo_J1_2_3) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  ASSERT_EQ(b.write_u16(0x1800, 5, 10).data[0], 0x60);
  b.nmt(0x01, 0x7F);
  b.run_for(25ms);
  const auto before = tpdo_positions(b, 0);
  ASSERT_FALSE(before.empty());
  EXPECT_EQ(before.back(), 0);

  std::size_t from = b.truth.size();
  b.device->move_by(0.25);
  b.run_for(10ms);
  auto after = tpdo_positions(b, from);
  ASSERT_EQ(after.size(), 1u);
  EXPECT_EQ(after.front(), 4096);

  from = b.truth.size();
  b.device->move_by(-0.5);
  b.run_for(10ms);
  after = tpdo_positions(b, from);
  ASSERT_EQ(after.size(), 1u);
  EXPECT_EQ(after.front(), 16384 - 4096);
  // The object dictionary says the same, and 0x6000 bit 0 (ccw, J§1.4.1)
  // mirrors it: total - 1 - count.
  EXPECT_EQ(Bench::value(b.read(0x6020, 1)), 12288u);
  b.nmt(0x80, 0x7F);
  ASSERT_EQ(b.write_u16(0x6000, 0, 0x0001).data[0], 0x60);
  b.run_for(2ms);
  EXPECT_EQ(Bench::value(b.read(0x6020, 1)), 16384u - 1u - 12288u);
}

// E§4.2 0x6501 = 0x10000 counts per turn: 1.5 turns = 0x18000 in the next
// TPDO1; the offset is the shaft's, so it survives a power cycle and a new
// motion (an absolute encoder sees where the shaft went).
TEST(SimDeviceMove, MultiturnOffsetSurvivesPowerCycleAndNewMotion_E4_2) {
  Bench b("MC1-2800", "novotechnik-multiturn.eds");
  b.power_on();
  ASSERT_EQ(b.write_u16(0x1800, 5, 10).data[0], 0x60);
  b.nmt(0x01, 0x7F);
  b.run_for(15ms);
  std::size_t from = b.truth.size();
  b.device->move_by(1.5);
  b.run_for(10ms);
  const auto after = tpdo_positions(b, from);
  ASSERT_EQ(after.size(), 1u);
  EXPECT_EQ(after.front(), 0x18000);

  b.power_cycle();
  b.run_for(2ms);
  EXPECT_EQ(Bench::value(b.read(0x6004, 0)), 0x18000u);
  ASSERT_FALSE(b.device->set_motion("steps:0=1", b.now));
  b.run_for(2ms);
  EXPECT_EQ(Bench::value(b.read(0x6004, 0)), 0x28000u);
}

// E§10.1 bit 19 "speed out of range", E§10.3 bit 6 "speed range limit":
// 10 turns/s = 3600 deg/s = 36000 in 0.1 deg/s (E§3.4) does not fit
// INTEGER16; 0x6030/1 saturates at 32767 and both bits are set while it
// lasts, and clear at 5 turns/s (18000).
TEST(SimDeviceSpeed, MultiturnSpeedOutOfRangeBits_E10_1) {
  DeviceSpec spec;
  spec.motion = "constant:10";
  Bench b("MC1-2800", "novotechnik-multiturn.eds", spec);
  b.power_on();
  b.run_for(10ms);
  EXPECT_EQ(Bench::value(b.read(0x6030, 1)) & 0xFFFFu, 32767u);
  EXPECT_NE(Bench::value(b.read(0x1002, 0)) & (1u << 19), 0u);
  EXPECT_NE(Bench::value(b.read(0x6505, 0)) & (1u << 6), 0u);
  ASSERT_FALSE(b.device->set_motion("constant:5", b.now));
  b.run_for(10ms);
  EXPECT_EQ(Bench::value(b.read(0x6030, 1)) & 0xFFFFu, 18000u);
  EXPECT_EQ(Bench::value(b.read(0x1002, 0)) & (1u << 19), 0u);
  EXPECT_EQ(Bench::value(b.read(0x6505, 0)) & (1u << 6), 0u);
}

}  // namespace
}  // namespace cobridge::sim::test
