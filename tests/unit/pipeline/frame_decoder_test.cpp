// FrameDecoder: TPDO/EMCY/heartbeat frames -> samples, with the seed
// devices' default mappings (J§1.7.2, E§4.1, F§7.3) and CiA 301 rules.
#include "pipeline/frame_decoder.hpp"

#include <gtest/gtest.h>

#include <vector>

using namespace cobridge;
using namespace cobridge::pipeline;

namespace {

DecodePlan plan_for(std::uint8_t node, std::vector<MappedObject> tpdo1, std::vector<MappedObject> tpdo2 = {}) {
  DecodePlan p;
  p.active = true;
  p.indexed = true;
  p.node_id = node;
  p.device_index = static_cast<std::uint16_t>(node + 100);
  const cobridge::Error err1 = build_pdo_decode(tpdo1, p.tpdo[0]);
  EXPECT_TRUE(err1.ok()) << err1.message;
  const cobridge::Error err2 = build_pdo_decode(tpdo2, p.tpdo[1]);
  EXPECT_TRUE(err2.ok()) << err2.message;
  return p;
}

can::Frame frame(std::uint32_t id, std::initializer_list<std::uint8_t> bytes, std::int64_t ts = 1000) {
  can::Frame f = can::Frame::make(id, bytes);
  f.timestamp_ns = ts;
  return f;
}

}  // namespace

// J§1.7.2: rotary 1-channel default TPDO1 = position ch1 (INTEGER32) | speed ch1 (INTEGER16).
TEST(FrameDecoder, J_1_7_2_RotaryDefaultMappingPositionAndSpeed) {
  DeviceTable table;
  table.publish(plan_for(5, {{0x60200120, true}, {0x60300110, true}}));
  FrameDecoder d(2, table);
  Sample s;
  ASSERT_TRUE(d.decode(frame(0x185, {0x00, 0x20, 0x00, 0x00, 0x9C, 0xFF}, 4242), s));
  EXPECT_EQ(s.kind, COBRIDGE_SAMPLE_TPDO);
  EXPECT_EQ(s.node_id, 5);
  EXPECT_EQ(s.bus_index, 2);
  EXPECT_EQ(s.device_index, 105);
  EXPECT_EQ(s.position, 0x2000);
  EXPECT_EQ(s.speed, -100);
  EXPECT_EQ(s.rx_timestamp_ns, 4242u);
  EXPECT_EQ(s.cob_id, 0x185);
  EXPECT_TRUE(s.valid & COBRIDGE_VALID_POSITION);
  EXPECT_TRUE(s.valid & COBRIDGE_VALID_SPEED);
  EXPECT_FALSE(s.valid & COBRIDGE_VALID_CAM_STATE);
  EXPECT_EQ(s.sequence, 1u);
}

// E§9.1: the multiturn error position 0x80000008 is a negative INTEGER32 (0x6004).
TEST(FrameDecoder, E_9_1_MultiturnNegativeSentinelSignExtends) {
  DeviceTable table;
  table.publish(plan_for(9, {{0x60040020, true}, {0x63000108, false}, {0x64000108, false}}));
  FrameDecoder d(0, table);
  Sample s;
  ASSERT_TRUE(d.decode(frame(0x189, {0x08, 0x00, 0x00, 0x80, 0x05, 0x02}), s));
  EXPECT_EQ(s.position, -2147483640);
  EXPECT_EQ(s.cam_state, 0x05);
  EXPECT_EQ(s.work_area_state, 0x02);
}

// F§7.4 0x2104/0x2105: ifm position is UNSIGNED32 with limit-switch bits 30/31;
// with the mask the position is bits 29..0.
TEST(FrameDecoder, F_7_4_IfmLimitSwitchBitsMaskedFromPosition) {
  DeviceTable table;
  DecodePlan p = plan_for(32, {{0x60040020, false}});
  p.position_mask = 0x3FFFFFFF;
  table.publish(p);
  FrameDecoder d(0, table);
  Sample s;
  ASSERT_TRUE(d.decode(frame(0x1A0, {0x10, 0x00, 0x00, 0x80}), s));  // bit 31 + value 16
  EXPECT_EQ(s.position, 16);
  EXPECT_EQ(s.raw[3], 0x80);
}

// CiA 301 §7.2.2: a PDO shorter than its mapping is not processed.
TEST(FrameDecoder, CiA301_ShortPdoIsCountedNotDecoded) {
  DeviceTable table;
  table.publish(plan_for(5, {{0x60200120, true}, {0x60300110, true}}));
  FrameDecoder d(0, table);
  Sample s;
  EXPECT_FALSE(d.decode(frame(0x185, {0x00, 0x20, 0x00, 0x00}), s));
  EXPECT_EQ(d.stats().bad_length, 1u);
  EXPECT_EQ(d.stats().samples, 0u);
}

TEST(FrameDecoder, PdoOfUnknownNodeIsCounted) {
  DeviceTable table;
  FrameDecoder d(0, table);
  Sample s;
  EXPECT_FALSE(d.decode(frame(0x187, {1, 2, 3, 4}), s));
  EXPECT_EQ(d.stats().unknown_node, 1u);
}

// J§1.8.1: EMCY 0x9080 CAM change, bytes as printed (b3-4 channel, b5-6 mask, b7 state).
TEST(FrameDecoder, J_1_8_1_EmcyBecomesEmcySample) {
  DeviceTable table;
  FrameDecoder d(0, table);
  Sample s;
  // A node no device index belongs to is never published
  // (it used to land on device index 0, another device's slot); it is counted.
  ASSERT_FALSE(d.decode(frame(0x085, {0x80, 0x90, 0x01, 0x01, 0x00, 0x02, 0x00, 0x02}), s));
  EXPECT_EQ(d.stats().unknown_node, 1u);
  table.publish_index(5, 7);
  d.refresh();
  ASSERT_TRUE(d.decode(frame(0x085, {0x80, 0x90, 0x01, 0x01, 0x00, 0x02, 0x00, 0x02}), s));
  EXPECT_EQ(s.kind, COBRIDGE_SAMPLE_EMCY);
  EXPECT_EQ(s.device_index, 7);
  EXPECT_EQ(s.emcy_code, 0x9080);
  EXPECT_EQ(s.emcy_register, 0x01);
  EXPECT_EQ(s.emcy_data[0], 0x01);
  EXPECT_EQ(s.emcy_data[4], 0x02);
  // CiA 301 §7.2.7.3.1: EMCY frames are 8 bytes.
  EXPECT_FALSE(d.decode(frame(0x085, {0x00, 0x50, 0x01}), s));
  EXPECT_EQ(d.stats().bad_length, 1u);
}

// CiA 301 §7.2.8.3.2: heartbeat byte = NMT state; boot-up = 0x00.
TEST(FrameDecoder, CiA301_HeartbeatCarriesNmtState) {
  DeviceTable table;
  FrameDecoder d(0, table);
  Sample s;
  EXPECT_FALSE(d.decode(frame(0x77F, {0x05}), s)) << "no device index at node 127 yet";
  Sample status;
  EXPECT_FALSE(d.make_status(127, true, false, COBRIDGE_NMT_OPERATIONAL, 1, status)) << "nor a status sample";
  EXPECT_EQ(d.stats().unknown_node, 2u);
  table.publish_index(127, 3);
  d.refresh();
  ASSERT_TRUE(d.decode(frame(0x77F, {0x05}), s));
  EXPECT_EQ(s.device_index, 3);
  EXPECT_EQ(s.kind, COBRIDGE_SAMPLE_HEARTBEAT);
  EXPECT_EQ(s.node_id, 127);
  EXPECT_EQ(s.nmt_state, COBRIDGE_NMT_OPERATIONAL);
  ASSERT_TRUE(d.decode(frame(0x77F, {0x00}), s));
  EXPECT_EQ(s.nmt_state, COBRIDGE_NMT_BOOT_UP);
}

// While no plan changes, refresh() is one atomic load: no
// lock, no copy of the table, also before the first plan exists.
TEST(FrameDecoder, RefreshCopiesOnlyAfterAChange) {
  DeviceTable table;
  FrameDecoder d(0, table);
  const std::uint32_t copies = table.snapshots();
  for (int i = 0; i < 1000; ++i) d.refresh();
  EXPECT_EQ(table.snapshots(), copies);
  table.publish_index(9, 1);
  for (int i = 0; i < 1000; ++i) d.refresh();
  EXPECT_EQ(table.snapshots(), copies + 1);
}

// A device that moved: its old node-ID's frames are no longer its own.
TEST(FrameDecoder, RemovedNodeIsUnknownAgain) {
  DeviceTable table;
  table.publish_index(9, 1);
  FrameDecoder d(0, table);
  Sample s;
  ASSERT_TRUE(d.decode(frame(0x709, {0x05}), s));
  table.remove(9);
  d.refresh();
  EXPECT_FALSE(d.decode(frame(0x709, {0x05}), s));
}

// Every sample of a device, of any kind, takes the next sequence number.
TEST(FrameDecoder, SequencePerDeviceAcrossKinds) {
  DeviceTable table;
  table.publish(plan_for(5, {{0x60200120, true}}));
  table.publish(plan_for(6, {{0x60200120, true}}));
  FrameDecoder d(0, table);
  Sample s;
  ASSERT_TRUE(d.decode(frame(0x185, {1, 0, 0, 0}), s));
  EXPECT_EQ(s.sequence, 1u);
  ASSERT_TRUE(d.decode(frame(0x186, {1, 0, 0, 0}), s));
  EXPECT_EQ(s.sequence, 1u);
  ASSERT_TRUE(d.decode(frame(0x705, {0x05}), s));
  EXPECT_EQ(s.sequence, 2u);
  ASSERT_TRUE(d.make_status(5, false, false, COBRIDGE_NMT_OPERATIONAL, 5, s));
  EXPECT_EQ(s.sequence, 3u);
  EXPECT_EQ(s.kind, COBRIDGE_SAMPLE_STATUS);
  EXPECT_EQ(s.online, 0);
  EXPECT_EQ(s.stale, 1) << "an offline device's values are stale";
}

// kind_sequence counts each kind of each device on its own, so a
// gap in the TPDOs of a device (what DDS EncoderSample numbers by) is a lost
// TPDO, never a heartbeat or EMCY in between.
TEST(FrameDecoder, KindSequencePerDeviceAndKind) {
  DeviceTable table;
  table.publish(plan_for(5, {{0x60200120, true}}));
  table.publish(plan_for(6, {{0x60200120, true}}));
  FrameDecoder d(0, table);
  Sample s;
  ASSERT_TRUE(d.decode(frame(0x185, {1, 0, 0, 0}), s));
  EXPECT_NE(s.valid & COBRIDGE_VALID_KIND_SEQUENCE, 0);
  EXPECT_EQ(s.kind_sequence, 1u);
  ASSERT_TRUE(d.decode(frame(0x705, {0x05}), s));  // heartbeat: its own count
  EXPECT_EQ(s.kind_sequence, 1u);
  EXPECT_EQ(s.sequence, 2u);
  ASSERT_TRUE(d.decode(frame(0x085, {0x00, 0x10, 0x01, 0, 0, 0, 0, 0}), s));  // EMCY
  EXPECT_EQ(s.kind_sequence, 1u);
  ASSERT_TRUE(d.decode(frame(0x186, {1, 0, 0, 0}), s));  // another device: its own count
  EXPECT_EQ(s.kind_sequence, 1u);
  ASSERT_TRUE(d.decode(frame(0x185, {2, 0, 0, 0}), s));
  EXPECT_EQ(s.kind, COBRIDGE_SAMPLE_TPDO);
  EXPECT_EQ(s.kind_sequence, 2u) << "the TPDOs of node 5 count on, past its heartbeat and EMCY";
  EXPECT_EQ(s.sequence, 4u);
  ASSERT_TRUE(d.decode(frame(0x705, {0x05}), s));
  EXPECT_EQ(s.kind_sequence, 2u);
  ASSERT_TRUE(d.make_status(5, false, false, COBRIDGE_NMT_OPERATIONAL, 5, s));
  EXPECT_EQ(s.kind_sequence, 1u);
  EXPECT_NE(s.valid & COBRIDGE_VALID_KIND_SEQUENCE, 0);
}

// A device already reported stale stays stale in a later status sample.
TEST(FrameDecoder, StatusKeepsKnownStaleness) {
  DeviceTable table;
  DecodePlan p = plan_for(5, {{0x60200120, true}});
  p.max_age_ms = 10;
  table.publish(p);
  FrameDecoder d(0, table);
  Sample s;
  ASSERT_TRUE(d.decode(frame(0x185, {1, 0, 0, 0}, 1'000'000'000), s));
  d.check_stale(1'050'000'000, [](std::uint8_t) {});
  ASSERT_TRUE(d.make_status(5, true, false, COBRIDGE_NMT_OPERATIONAL, 1'060'000'000, s));
  EXPECT_EQ(s.stale, 1);
  ASSERT_TRUE(d.decode(frame(0x185, {2, 0, 0, 0}, 1'070'000'000), s));
  ASSERT_TRUE(d.make_status(5, true, false, COBRIDGE_NMT_OPERATIONAL, 1'080'000'000, s));
  EXPECT_EQ(s.stale, 0) << "fresh data clears it";
}

// CiA 301 §7.2.5.3.3: a synchronous TPDO carries the counter of its SYNC.
TEST(FrameDecoder, CiA301_SynchronousTpdoCarriesSyncCounter) {
  DeviceTable table;
  DecodePlan p = plan_for(5, {{0x60200120, true}}, {{0x60200120, true}});
  p.synchronous = {false, true};
  table.publish(p);
  FrameDecoder d(0, table);
  Sample s;
  EXPECT_FALSE(d.decode(frame(0x080, {17}), s));
  ASSERT_TRUE(d.decode(frame(0x285, {1, 0, 0, 0}), s));
  EXPECT_EQ(s.sync_counter, 17);
  ASSERT_TRUE(d.decode(frame(0x185, {1, 0, 0, 0}), s));
  EXPECT_EQ(s.sync_counter, 0) << "an event-driven TPDO is not tied to a SYNC";
}

// A plan published after construction is picked up by refresh(), not before.
TEST(FrameDecoder, NewPlansTakeEffectOnRefresh) {
  DeviceTable table;
  FrameDecoder d(0, table);
  table.publish(plan_for(5, {{0x60200120, true}}));
  Sample s;
  EXPECT_FALSE(d.decode(frame(0x185, {1, 0, 0, 0}), s));
  d.refresh();
  EXPECT_TRUE(d.decode(frame(0x185, {1, 0, 0, 0}), s));
  table.remove(5);
  d.refresh();
  EXPECT_FALSE(d.decode(frame(0x185, {1, 0, 0, 0}), s));
}

// Values older than max_age are reported stale once; a new TPDO clears it.
TEST(FrameDecoder, StaleReportedOnceThenClearedByNewData) {
  DeviceTable table;
  DecodePlan p = plan_for(5, {{0x60200120, true}});
  p.max_age_ms = 10;
  table.publish(p);
  FrameDecoder d(0, table);
  Sample s;
  ASSERT_TRUE(d.decode(frame(0x185, {1, 0, 0, 0}, 1'000'000'000), s));
  int reported = 0;
  d.check_stale(1'005'000'000, [&](std::uint8_t) { ++reported; });
  EXPECT_EQ(reported, 0);
  d.check_stale(1'011'000'000, [&](std::uint8_t n) {
    ++reported;
    EXPECT_EQ(n, 5);
  });
  d.check_stale(1'020'000'000, [&](std::uint8_t) { ++reported; });
  EXPECT_EQ(reported, 1);
  ASSERT_TRUE(d.decode(frame(0x185, {1, 0, 0, 0}, 1'030'000'000), s));
  d.check_stale(1'050'000'000, [&](std::uint8_t) { ++reported; });
  EXPECT_EQ(reported, 2);
}

// Ages are judged on CLOCK_MONOTONIC. The wall clock steps
// an hour forward between two frames (NTP, an operator): fresh data stays
// fresh, and samples keep the wall-clock time for the outputs.
TEST(FrameDecoder, WallClockStepDoesNotMakeFreshDataStale) {
  DeviceTable table;
  DecodePlan p = plan_for(5, {{0x60200120, true}});
  p.max_age_ms = 10;
  table.publish(p);
  FrameDecoder d(0, table);
  constexpr std::int64_t kWall = 1'700'000'000'000'000'000;
  constexpr std::int64_t kMono = 50'000'000'000;
  d.set_clocks(kWall, kMono);
  Sample s;
  ASSERT_TRUE(d.decode(frame(0x185, {1, 0, 0, 0}, kWall), s));
  EXPECT_EQ(s.rx_timestamp_ns, static_cast<std::uint64_t>(kWall));
  EXPECT_EQ(s.rx_monotonic_ns, static_cast<std::uint64_t>(kMono));
  EXPECT_NE(s.valid & COBRIDGE_VALID_RX_MONOTONIC, 0);
  constexpr std::int64_t kStep = 3600LL * 1'000'000'000;
  d.set_clocks(kWall + kStep + 4'000'000, kMono + 4'000'000);  // 4 ms later, wall clock +1 h
  ASSERT_TRUE(d.decode(frame(0x185, {2, 0, 0, 0}, kWall + kStep + 4'000'000), s));
  EXPECT_EQ(s.rx_monotonic_ns, static_cast<std::uint64_t>(kMono + 4'000'000));
  int stale = 0;
  d.check_stale(kMono + 9'000'000, [&](std::uint8_t) { ++stale; });
  EXPECT_EQ(stale, 0) << "5 ms old on the monotonic clock";
  d.check_stale(kMono + 15'000'000, [&](std::uint8_t) { ++stale; });
  EXPECT_EQ(stale, 1);
}

TEST(DecodePlan, RejectsUndecodableMappings) {
  PdoDecode out;
  std::vector<MappedObject> too_long = {{0x60040020, true}, {0x60040020, true}, {0x63000108, false}};
  const cobridge::Error err = build_pdo_decode(too_long, out);
  EXPECT_FALSE(err.ok());
  EXPECT_NE(err.message.find("64 bits"), std::string::npos);
  std::vector<MappedObject> zero = {{0x60040000, true}};
  EXPECT_FALSE(build_pdo_decode(zero, out).ok());
  std::vector<MappedObject> ok = {{0x60040020, true}, {0x63000108, false}, {0x64000108, false}};
  ASSERT_TRUE(build_pdo_decode(ok, out).ok());
  EXPECT_EQ(out.frame_length, 6);
}
