// SimDevice TPDOs: event timer, SYNC, inhibit time, measuring cycle, RTR.
#include "sim_bench.hpp"

namespace cobridge::sim::test {
namespace {

std::size_t count_id(const Bench& b, std::uint32_t id, std::size_t from) { return b.frames_with_id(id, from).size(); }

// J§1.3.1 0x1800/5 (1 ms supported), A.3: type 254 with a 1 ms event timer
// sends exactly 1000 frames per second with the mapped values (J§1.7.2
// default mapping: position ch1 INTEGER32 + speed ch1 INTEGER16).
TEST(SimDeviceTpdo, EventTimer1msGives1000FramesPerSecond_J1_3_1) {
  DeviceSpec spec;
  spec.motion = "constant:0";
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds", spec);
  b.power_on();
  ASSERT_EQ(b.write_u16(0x1800, 5, 1).data[0], 0x60);
  b.nmt(0x01, 0x7F);
  const std::size_t from = b.rec.frames.size();
  b.run_for(1000ms);
  const auto pdos = b.frames_with_id(0x1FF, from);
  EXPECT_EQ(pdos.size(), 1000u);
  ASSERT_FALSE(pdos.empty());
  const auto* od = b.device->object_dictionary();
  const auto pos = static_cast<std::uint32_t>(*od->get_i32(0x6020, 1));
  EXPECT_EQ(pdos.back().len, 6);
  EXPECT_EQ(pdos.back().data[0], static_cast<std::uint8_t>(pos));
  EXPECT_EQ(pdos.back().data[3], static_cast<std::uint8_t>(pos >> 24));
  // Truth records decode the same values.
  std::size_t tpdo_truth = 0;
  for (const auto& r : b.truth)
    if (r.kind == TruthRecord::Kind::tpdo) {
      ++tpdo_truth;
      EXPECT_TRUE(r.has_position);
      EXPECT_EQ(r.position, static_cast<std::int32_t>(pos));
      EXPECT_TRUE(r.has_speed);
      EXPECT_EQ(r.pdo, 1);
    }
  EXPECT_EQ(tpdo_truth, 1000u);
  // Not in pre-operational (F§6.1.1, CiA 301: PDOs only when operational).
  b.nmt(0x80, 0x7F);
  const std::size_t from2 = b.rec.frames.size();
  b.run_for(100ms);
  EXPECT_EQ(count_id(b, 0x1FF, from2), 0u);
}

// J§1.3.1: default type 254 with event timer 0 is silent.
TEST(SimDeviceTpdo, DefaultTpdo1IsSilent_A3) {
  Bench b("MC1-2800", "novotechnik-multiturn.eds");
  b.power_on();
  b.nmt(0x01, 0x7F);
  const std::size_t from = b.rec.frames.size();
  b.run_for(500ms);
  EXPECT_EQ(count_id(b, 0x1FF, from), 0u);
}

// J§1.3.1 0x1801/2: TPDO2 type n = every n-th SYNC (default 1).
TEST(SimDeviceTpdo, SyncEveryNth_J1_3_1) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  ASSERT_EQ(b.write_u8(0x1801, 2, 3).data[0], 0x60);
  b.nmt(0x01, 0x7F);
  const std::size_t from = b.rec.frames.size();
  for (int i = 0; i < 9; ++i) {
    b.run_for(10ms);
    b.deliver(Frame::make(0x080, {}));
  }
  EXPECT_EQ(count_id(b, 0x2FF, from), 3u);
  // Each transmission happens at the SYNC itself.
  ASSERT_EQ(b.write_u8(0x1801, 2, 1).data[0], 0x60);
  const std::size_t from2 = b.rec.frames.size();
  b.deliver(Frame::make(0x080, {}));
  EXPECT_EQ(count_id(b, 0x2FF, from2), 1u);
}

// J§1.2.5: type 255 sends every 1 ms measuring cycle; the
// inhibit time (0x1800/3, 100 us units) spaces the frames.
TEST(SimDeviceTpdo, Type255AndInhibit_J1_2_5) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  ASSERT_EQ(b.write_u8(0x1800, 2, 255).data[0], 0x60);
  b.nmt(0x01, 0x7F);
  std::size_t from = b.rec.frames.size();
  b.run_for(100ms);
  EXPECT_NEAR(static_cast<double>(count_id(b, 0x1FF, from)), 100.0, 1.0);
  b.nmt(0x80, 0x7F);
  ASSERT_EQ(b.write_u16(0x1800, 3, 50).data[0], 0x60);  // 5 ms
  b.nmt(0x01, 0x7F);
  from = b.rec.frames.size();
  b.run_for(100ms);
  EXPECT_NEAR(static_cast<double>(count_id(b, 0x1FF, from)), 20.0, 1.0);
}

// F§7.3: ifm answers a remote request on the TPDO COB-ID (bit 30 clear).
// Novotechnik does not (J: no RTR, bit 30 set by default).
TEST(SimDeviceTpdo, RtrOnlyOnIfm_F7_3) {
  Bench f("RM9000", "ifm-rm8-rm9.eds");
  f.power_on();
  ASSERT_EQ(f.write_u8(0x1800, 2, 253).data[0], 0x60);
  f.nmt(0x01, 32);
  Frame rtr = Frame::make(0x1A0, {});
  rtr.flags = Frame::kFlagRtr;
  rtr.len = 4;
  std::size_t from = f.rec.frames.size();
  f.deliver(rtr);
  const auto got = f.frames_with_id(0x1A0, from);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].len, 4);

  Bench j("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  j.power_on();
  j.nmt(0x01, 0x7F);
  rtr.id = 0x1FF;
  from = j.rec.frames.size();
  j.deliver(rtr);
  EXPECT_EQ(count_id(j, 0x1FF, from), 0u);
}

// F§7.3, F§7.5 0x6200: ifm TPDO1 default type 254 with 100 ms timer;
// TPDO2 only on C6 variants.
TEST(SimDeviceTpdo, IfmDefaultsAndC6_F7_3) {
  Bench plain("RM9000", "ifm-rm8-rm9.eds");
  plain.power_on();
  plain.nmt(0x01, 32);
  std::size_t from = plain.rec.frames.size();
  plain.run_for(1000ms);
  EXPECT_EQ(count_id(plain, 0x1A0, from), 10u);
  for (int i = 0; i < 3; ++i) plain.deliver(Frame::make(0x080, {}));
  EXPECT_EQ(count_id(plain, 0x2A0, from), 0u);

  DeviceSpec spec;
  spec.ifm_c6 = true;
  Bench c6("RM9000", "ifm-rm8-rm9.eds", spec);
  c6.power_on();
  c6.nmt(0x01, 32);
  from = c6.rec.frames.size();
  for (int i = 0; i < 3; ++i) c6.deliver(Frame::make(0x080, {}));
  EXPECT_EQ(count_id(c6, 0x2A0, from), 3u);
}

}  // namespace
}  // namespace cobridge::sim::test
