// SimDevice LSS slave (J§1.5, E§6, CiA 305): selective switch with the
// identity, configure + store + power cycle, state restrictions, versions.
#include "sim_bench.hpp"

namespace cobridge::sim::test {
namespace {

Frame lss(std::initializer_list<std::uint8_t> bytes) {
  std::array<std::uint8_t, 8> a{};
  std::size_t i = 0;
  for (auto v : bytes) a[i++] = v;
  return Frame::make8(0x7E5, a);
}

// J§1.5 switch mode selective (the manual's four frames answer 0x44), then
// J§1.5.1 configure node-ID, J§1.5.3 store, and after a power cycle the
// device boots with the new node-ID (CiA 305).
TEST(SimDeviceLss, ConfigureStorePowerCycle_J1_5) {
  const auto dir = temp_state_dir("lss");
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds", {}, dir);
  b.power_on();
  const std::size_t from = b.rec.frames.size();
  b.deliver(lss({0x40, 0x82, 0x01, 0x00, 0x00}));
  b.deliver(lss({0x41, 0xE0, 0x0B, 0x00, 0x00}));
  b.deliver(lss({0x42, 0x03, 0x00, 0x01, 0x00}));
  b.deliver(lss({0x43, 0x78, 0x56, 0x34, 0x12}));
  auto answers = b.frames_with_id(0x7E4, from);
  ASSERT_EQ(answers.size(), 1u);
  EXPECT_EQ(answers[0], Frame::make8(0x7E4, {0x44, 0, 0, 0, 0, 0, 0, 0}));
  b.deliver(lss({0x11, 0x21}));
  b.deliver(lss({0x17}));
  answers = b.frames_with_id(0x7E4, from);
  ASSERT_EQ(answers.size(), 3u);
  EXPECT_EQ(answers[1], Frame::make8(0x7E4, {0x11, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(answers[2], Frame::make8(0x7E4, {0x17, 0, 0, 0, 0, 0, 0, 0}));
  b.deliver(lss({0x04, 0x00}));
  EXPECT_EQ(b.device->node_id(), 0x7F);  // pending until reset / power-up
  b.power_cycle();
  EXPECT_EQ(b.device->node_id(), 0x21);
  EXPECT_EQ(b.rec.frames.back(), Frame::make(0x721, {0x00}));
  std::filesystem::remove_all(dir);
}

// CiA 305: a configured (not stored) node-ID becomes active with NMT reset
// communication; not stored -> lost after a power cycle.
TEST(SimDeviceLss, PendingActiveOnResetCommunication_CiA305) {
  Bench b("MC1-2800", "novotechnik-multiturn.eds", {}, temp_state_dir("lss2"));
  b.power_on();
  b.deliver(lss({0x04, 0x01}));
  b.deliver(lss({0x11, 0x30}));
  b.deliver(lss({0x04, 0x00}));
  b.nmt(0x82, 0x7F);
  EXPECT_EQ(b.device->node_id(), 0x30);
  EXPECT_EQ(b.rec.frames.back(), Frame::make(0x730, {0x00}));
  b.power_cycle();
  EXPECT_EQ(b.device->node_id(), 0x7F);
  std::filesystem::remove_all(temp_state_dir("lss2"));
}

// J§1.5, E§6: LSS only in stopped or pre-operational.
TEST(SimDeviceLss, IgnoredWhenOperational_E6) {
  Bench b("MC1-2800", "novotechnik-multiturn.eds");
  b.power_on();
  b.nmt(0x01, 0x7F);
  const std::size_t from = b.rec.frames.size();
  b.deliver(lss({0x04, 0x01}));
  b.deliver(lss({0x11, 0x30}));
  EXPECT_TRUE(b.frames_with_id(0x7E4, from).empty());
  b.nmt(0x02, 0x7F);
  b.deliver(lss({0x04, 0x01}));
  b.deliver(lss({0x11, 0x30}));
  EXPECT_EQ(b.frames_with_id(0x7E4, from).size(), 1u);
}

// CiA 305 V3 Fastscan: an unconfigured V3 slave answers Fastscan; configured by LSS
// it leaves configuration and resets communication on its own (CiA 305 V3),
// booting with the new ID.
TEST(SimDeviceLss, UnconfiguredGetsNodeIdByLss_Y2) {
  DeviceSpec spec;
  spec.node_id = 0xFF;
  Bench b("MC1-2800", "novotechnik-multiturn.eds", spec);
  b.power_on();
  b.deliver(lss({0x51, 0, 0, 0, 0, 0x80, 0, 0}));
  ASSERT_EQ(b.frames_with_id(0x7E4).size(), 1u);
  EXPECT_EQ(b.frames_with_id(0x7E4)[0].data[0], 0x4F);
  b.deliver(lss({0x04, 0x01}));
  b.deliver(lss({0x11, 0x12}));
  b.deliver(lss({0x04, 0x00}));
  EXPECT_EQ(b.device->node_id(), 0x12);
  EXPECT_EQ(b.rec.frames.back(), Frame::make(0x712, {0x00}));
}

// J claims DSP-305 V1.1.2 (J§1 intro): no Fastscan, no inquire; E (V3)
// answers inquire node-ID.
TEST(SimDeviceLss, VersionFeatureSets_A5_C5) {
  DeviceSpec spec;
  spec.node_id = 0xFF;
  Bench j("RFC-4800", "novotechnik-rfc4800-1ch.eds", spec);
  j.power_on();
  j.deliver(lss({0x51, 0, 0, 0, 0, 0x80, 0, 0}));
  j.deliver(lss({0x04, 0x01}));
  j.deliver(lss({0x5E}));
  EXPECT_TRUE(j.frames_with_id(0x7E4).empty());

  Bench e("MC1-2800", "novotechnik-multiturn.eds");
  e.power_on();
  e.deliver(lss({0x04, 0x01}));
  e.deliver(lss({0x5E}));
  const auto a = e.frames_with_id(0x7E4);
  ASSERT_EQ(a.size(), 1u);
  EXPECT_EQ(a[0], Frame::make8(0x7E4, {0x5E, 0x7F, 0, 0, 0, 0, 0, 0}));
}

// J§1.5.2, E§6.2: bit timing (CiA form) stored with 0x17 -> 0x2001 after power-up.
TEST(SimDeviceLss, BitTimingStored_E6_2) {
  const auto dir = temp_state_dir("lssbt");
  Bench b("MC1-2800", "novotechnik-multiturn.eds", {}, dir);
  b.power_on();
  b.deliver(lss({0x04, 0x01}));
  b.deliver(lss({0x13, 0x00, 0x02}));  // 500 kbit/s
  b.deliver(lss({0x17}));
  const auto a = b.frames_with_id(0x7E4);
  ASSERT_EQ(a.size(), 2u);
  EXPECT_EQ(a[0], Frame::make8(0x7E4, {0x13, 0, 0, 0, 0, 0, 0, 0}));
  b.deliver(lss({0x13, 0x00, 0x07}));  // 20 kbit/s: not supported
  EXPECT_EQ(b.frames_with_id(0x7E4).back(), Frame::make8(0x7E4, {0x13, 0x01, 0, 0, 0, 0, 0, 0}));
  b.power_cycle();
  EXPECT_EQ(b.device->bitrate_kbit(), 500);
  EXPECT_EQ(Bench::value(b.read(0x2001, 0)) & 0xFFFFu, 500u);
  std::filesystem::remove_all(dir);
}

// cobridge-sim `late_lss=2,late_lss_ms=150`: every 2nd LSS answer leaves
// 150 ms after its request, unchanged (CiA 305 §8.3 sets no answer time; a
// master's timeout does); the others at once.
TEST(SimDeviceLss, EverySecondAnswerLeavesLate_CiA305_8_3) {
  DeviceSpec spec;
  spec.late_lss = 2;
  spec.late_lss_ms = 150;
  Bench b("MC1-2800", "novotechnik-multiturn.eds", spec, temp_state_dir("lss-late"));
  b.power_on();
  const std::size_t from = b.rec.frames.size();
  b.deliver(lss({0x04, 0x01}));
  b.deliver(lss({0x5E}));  // inquire node-ID: 1st answer, at once
  ASSERT_EQ(b.frames_with_id(0x7E4, from).size(), 1u);
  b.deliver(lss({0x11, 0x30}));  // configure node-ID: 2nd answer, held
  EXPECT_EQ(b.frames_with_id(0x7E4, from).size(), 1u);
  b.run_for(149ms);
  EXPECT_EQ(b.frames_with_id(0x7E4, from).size(), 1u);
  b.run_for(1ms);
  const auto answers = b.frames_with_id(0x7E4, from);
  ASSERT_EQ(answers.size(), 2u);
  EXPECT_EQ(answers[1], Frame::make8(0x7E4, {0x11, 0, 0, 0, 0, 0, 0, 0}));
  b.deliver(lss({0x17}));  // store: 3rd answer, at once
  EXPECT_EQ(b.frames_with_id(0x7E4, from).size(), 3u);
  std::filesystem::remove_all(temp_state_dir("lss-late"));
}

}  // namespace
}  // namespace cobridge::sim::test
