// SimDevice EMCY producer: CAM / work-area changes and injected faults,
// bytes as J§1.8.1 and E§9.1 print them, and the error position values.
#include "sim_bench.hpp"

namespace cobridge::sim::test {
namespace {

std::vector<Frame> emcys(const Bench& b, std::size_t from, std::uint16_t code) {
  std::vector<Frame> out;
  for (const Frame& f : b.frames_with_id(0x80U + b.device->node_id(), from))
    if (static_cast<std::uint16_t>(f.data[0] | (f.data[1] << 8)) == code) out.push_back(f);
  return out;
}

// J§1.4.5, J§1.8.1 0x9080: a CAM change sends channel, changed CAMs, new
// state; J§1.4.6 0x9090 a work-area change sends channel and new state.
TEST(SimDeviceEmcy, CamAndWorkAreaChange_J1_8_1) {
  DeviceSpec spec;
  spec.motion = "steps:0=0;0.5=0.25";  // 0.25 turn = 4096 counts at 0.5 s
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds", spec);
  b.power_on();
  ASSERT_EQ(b.write_u32(0x6310, 1, 1000).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x6320, 1, 5000).data[0], 0x60);
  ASSERT_EQ(b.write_u8(0x6301, 1, 0x01).data[0], 0x60);
  const std::size_t from = b.rec.frames.size();
  b.run_for(1000ms);
  const auto cam = emcys(b, from, 0x9080);
  ASSERT_EQ(cam.size(), 1u);
  EXPECT_EQ(cam[0], Frame::make8(0xFF, {0x80, 0x90, 0x01, 0x01, 0x00, 0x01, 0x00, 0x01}));
  EXPECT_EQ(Bench::value(b.read(0x6300, 1)) & 0xFFu, 0x01u);
  const auto wa = emcys(b, from, 0x9090);
  ASSERT_EQ(wa.size(), 1u);  // bit 0 "out of range" (pos <= preset, J§1.4.6.1) clears
  EXPECT_EQ(wa[0], Frame::make8(0xFF, {0x90, 0x90, 0x01, 0x01, 0x00, 0x00, 0x00, 0x00}));
  bool truth_emcy = false;
  for (const auto& r : b.truth)
    if (r.kind == TruthRecord::Kind::emcy && r.emcy_code == 0x9080) truth_emcy = true;
  EXPECT_TRUE(truth_emcy);
}

// E§9.1 0x9080: byte 4 = changed CAMs, byte 7 = CAM state.
TEST(SimDeviceEmcy, MultiturnCamChange_E9_1) {
  DeviceSpec spec;
  spec.motion = "steps:0=0;0.5=2";  // 2 turns = 0x20000
  Bench b("MC1-2800", "novotechnik-multiturn.eds", spec);
  b.power_on();
  ASSERT_EQ(b.write_u32(0x6311, 1, 0x10000).data[0], 0x60);  // CAM2 low
  ASSERT_EQ(b.write_u32(0x6321, 1, 0x30000).data[0], 0x60);  // CAM2 high
  ASSERT_EQ(b.write_u8(0x6301, 1, 0x02).data[0], 0x60);
  const std::size_t from = b.rec.frames.size();
  b.run_for(1000ms);
  const auto cam = emcys(b, from, 0x9080);
  ASSERT_EQ(cam.size(), 1u);
  EXPECT_EQ(cam[0], Frame::make8(0xFF, {0x80, 0x90, 0x01, 0x00, 0x02, 0x00, 0x00, 0x02}));
}

// J§1.8, J§1.8.1 0x5000: sensor error -> EMCY, position 0x7FF0, speed 0,
// alarm bit 12 (J§1.9.2), 0x1001 set; the end -> EMCY 0x0000.
TEST(SimDeviceEmcy, RotarySensorError_J1_8_1) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  std::size_t from = b.rec.frames.size();
  b.device->inject(FaultKind::measurement_error, b.now);
  b.run_for(2ms);
  auto e = b.frames_with_id(0xFF, from);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0], Frame::make8(0xFF, {0x00, 0x50, 0x01, 0x01, 0x00, 0x01, 0x00, 0x00}));
  EXPECT_EQ(Bench::value(b.read(0x6020, 1)), 0x7FF0u);
  EXPECT_EQ(Bench::value(b.read(0x6030, 1)) & 0xFFFFu, 0u);
  EXPECT_EQ(Bench::value(b.read(0x6503, 0)) & 0xFFFFu, 0x1000u);
  EXPECT_EQ(Bench::value(b.read(0x1001, 0)) & 0xFFu, 0x01u);
  from = b.rec.frames.size();
  b.device->inject(FaultKind::clear, b.now);
  b.run_for(2ms);
  e = b.frames_with_id(0xFF, from);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0], Frame::make8(0xFF, {0, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(Bench::value(b.read(0x1001, 0)) & 0xFFu, 0x00u);
  EXPECT_NE(Bench::value(b.read(0x6020, 1)), 0x7FF0u);
}

// J§1.9.2 bit 0: 2-channel disagreement alarm.
TEST(SimDeviceEmcy, RotaryChannelDisagreement_J1_9_2) {
  Bench b("RFC-4800", "novotechnik-rfc4800-2ch.eds");
  b.power_on();
  b.device->inject(FaultKind::channel_disagreement, b.now);
  EXPECT_EQ(Bench::value(b.read(0x6503, 0)) & 0xFFFFu, 0x0001u);
}

// E§9.1 0x5051/1/0 measurement error: 0x7FFFFFFC; E§4.1 0x1029/2 = 0:
// operational -> pre-operational; E§10.2 alarm bit 0.
TEST(SimDeviceEmcy, MultiturnMeasurementError_E9_1) {
  Bench b("MC1-2800", "novotechnik-multiturn.eds");
  b.power_on();
  b.nmt(0x01, 0x7F);
  const std::size_t from = b.rec.frames.size();
  b.device->inject(FaultKind::measurement_error, b.now);
  b.run_for(2ms);
  const auto e = b.frames_with_id(0xFF, from);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0], Frame::make8(0xFF, {0x51, 0x50, 0x01, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(b.device->nmt_state(), canopen::NmtState::pre_operational);
  EXPECT_EQ(Bench::value(b.read(0x6004, 0)), 0x7FFFFFFCu);
  EXPECT_EQ(Bench::value(b.read(0x6503, 0)) & 0xFFFFu, 0x0001u);
  EXPECT_NE(Bench::value(b.read(0x1002, 0)) & (1u << 22), 0u);
}

// E§9.1 0x5051/1/1 and 1/2: position 0x7FFFFFF8 / 0x80000008, latched until
// the condition has ended AND 0x2100 is written (E§4.3); then EMCY 0x0000.
TEST(SimDeviceEmcy, MultiturnRangeErrorsLatchUntil2100_E4_3) {
  Bench b("MC1-2800", "novotechnik-multiturn.eds");
  b.power_on();
  std::size_t from = b.rec.frames.size();
  b.device->inject(FaultKind::over_range, b.now);
  b.run_for(2ms);
  auto e = b.frames_with_id(0xFF, from);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0], Frame::make8(0xFF, {0x51, 0x50, 0x01, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(Bench::value(b.read(0x6004, 0)), 0x7FFFFFF8u);
  EXPECT_EQ(Bench::value(b.read(0x6503, 0)) & 0xFFFFu, 0x2000u);  // E§10.2 bit 13
  // 0x2100 while the condition lasts: nothing changes.
  EXPECT_EQ(b.write_u8(0x2100, 0, 1).data[0], 0x60);
  EXPECT_EQ(Bench::value(b.read(0x6004, 0)), 0x7FFFFFF8u);
  from = b.rec.frames.size();
  b.device->inject(FaultKind::clear, b.now);
  b.run_for(2ms);
  EXPECT_TRUE(b.frames_with_id(0xFF, from).empty());  // still latched
  EXPECT_EQ(Bench::value(b.read(0x6004, 0)), 0x7FFFFFF8u);
  EXPECT_EQ(b.write_u8(0x2100, 0, 1).data[0], 0x60);
  b.run_for(2ms);
  e = b.frames_with_id(0xFF, from);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0], Frame::make8(0xFF, {0, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_NE(Bench::value(b.read(0x6004, 0)), 0x7FFFFFF8u);

  b.device->inject(FaultKind::under_range, b.now);
  b.run_for(2ms);
  EXPECT_EQ(Bench::value(b.read(0x6004, 0)), 0x80000008u);
}

// E§4.3 0x2104: 2 = Info and Warn suppressed; Hard always goes out.
TEST(SimDeviceEmcy, MultiturnLevelFilter_E4_3) {
  Bench b("MC1-2800", "novotechnik-multiturn.eds");
  b.power_on();
  ASSERT_EQ(b.write_u8(0x2104, 0, 2).data[0], 0x60);
  std::size_t from = b.rec.frames.size();
  b.device->inject(FaultKind::temperature_high, b.now);  // 0x4210/1/1 Warn
  b.run_for(2ms);
  EXPECT_TRUE(b.frames_with_id(0xFF, from).empty());
  EXPECT_NE(Bench::value(b.read(0x1002, 0)) & (1u << 4), 0u);  // E§10.1 bit 4 anyway
  b.device->inject(FaultKind::hardware_fault, b.now);  // 0x5000/1/0 Hard
  const auto e = b.frames_with_id(0xFF, from);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0], Frame::make8(0xFF, {0x00, 0x50, 0x01, 0x00, 0, 0, 0, 0}));
  ASSERT_EQ(b.write_u8(0x2104, 0, 0).data[0], 0x60);
  from = b.rec.frames.size();
  b.device->inject(FaultKind::voltage_low, b.now);  // 0x3100/1/2 Warn
  b.run_for(2ms);
  const auto v = b.frames_with_id(0xFF, from);
  ASSERT_EQ(v.size(), 1u);
  EXPECT_EQ(v[0], Frame::make8(0xFF, {0x00, 0x31, 0x01, 0x02, 0, 0, 0, 0}));
}

// F§4, F§7.3 0x1003: the error history keeps the last errors, cleared by
// writing 0 to sub 0. Codes are CiA 301 classes (F has none; F§4).
TEST(SimDeviceEmcy, IfmErrorHistory_F7_3) {
  Bench b("RM9000", "ifm-rm8-rm9.eds");
  b.power_on();
  const std::size_t from = b.rec.frames.size();
  b.device->inject(FaultKind::hardware_fault, b.now);
  const auto e = b.frames_with_id(0xA0, from);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0], Frame::make8(0xA0, {0x00, 0x50, 0x01, 0, 0, 0, 0, 0}));
  EXPECT_EQ(Bench::value(b.read(0x1003, 0)) & 0xFFu, 1u);
  EXPECT_EQ(Bench::value(b.read(0x1003, 1)), 0x5000u);
  EXPECT_EQ(b.write_u8(0x1003, 0, 0).data[0], 0x60);
  EXPECT_EQ(Bench::value(b.read(0x1003, 1)), 0u);
  EXPECT_EQ(Bench::abort_code(b.write_u8(0x1003, 0, 3)), 0x06090030u);
}

// CiA 301 §7.2.7: no EMCY in stopped.
TEST(SimDeviceEmcy, NoEmcyWhenStopped_CiA301_7_3_2_2) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  b.nmt(0x02, 0x7F);
  const std::size_t from = b.rec.frames.size();
  b.device->inject(FaultKind::hardware_fault, b.now);
  EXPECT_TRUE(b.frames_with_id(0xFF, from).empty());
}

// E§4.3, E§5.8: live values, boot counter (kept across power cycles in the
// history recorder), 0x2300/2 clears the lot size only.
TEST(SimDeviceCondition, CountersAndHistory_E5_8) {
  const auto dir = temp_state_dir("cm");
  DeviceSpec spec;
  spec.motion = "steps:0=0;0.2=1;0.4=0;0.6=1;0.8=0";
  Bench b("MC1-2800", "novotechnik-multiturn.eds", spec, dir);
  b.power_on();
  EXPECT_EQ(Bench::value(b.read(0x2310, 2)), 1u);
  EXPECT_EQ(Bench::value(b.read(0x2002, 0)) & 0xFFFFu, 350u);  // 35.0 degC
  EXPECT_EQ(Bench::value(b.read(0x2003, 0)) & 0xFFFFu, 240u);  // 24.0 V
  // Lot size on CAM1 rising edges (0x233A = 1); CAM1 = [0x8000, 0x18000].
  ASSERT_EQ(b.write_u32(0x6310, 1, 0x8000).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x6320, 1, 0x18000).data[0], 0x60);
  ASSERT_EQ(b.write_u8(0x6301, 1, 0x01).data[0], 0x60);
  ASSERT_EQ(b.write_u8(0x233A, 0, 1).data[0], 0x60);
  b.run_for(1000ms);
  EXPECT_EQ(Bench::value(b.read(0x2330, 2)), 2u);
  EXPECT_GE(Bench::value(b.read(0x2340, 1)), 3u);  // odometer in turns
  b.power_cycle();
  EXPECT_EQ(Bench::value(b.read(0x2310, 2)), 2u);
  EXPECT_EQ(Bench::value(b.read(0x2340, 1)), 0u);  // "since power-on" restarts
  EXPECT_EQ(b.write_u8(0x2300, 2, 1).data[0], 0x60);
  EXPECT_EQ(Bench::value(b.read(0x2330, 2)), 0u);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace cobridge::sim::test
