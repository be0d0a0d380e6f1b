// SimDevice NMT slave, boot-up, heartbeat, node guarding and identity.
#include "sim_bench.hpp"

namespace cobridge::sim::test {
namespace {

// CiA 301 §7.2.8.3.3 (J, E silent; F§6.1.1): boot-up 0x700+ID, one byte 00.
TEST(SimDeviceNmt, BootUpOnPowerOn_CiA301_7_2_8_3_3) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  ASSERT_EQ(b.rec.frames.size(), 1u);
  EXPECT_EQ(b.rec.frames[0], Frame::make(0x77F, {0x00}));
  EXPECT_EQ(b.device->nmt_state(), canopen::NmtState::pre_operational);
  ASSERT_EQ(b.truth.size(), 1u);
  EXPECT_EQ(b.truth[0].kind, TruthRecord::Kind::boot_up);
  EXPECT_EQ(b.truth[0].serial, 0x12345678u);
}

// F§5.3.1: ifm ships at node 32.
TEST(SimDeviceNmt, IfmBootsAtNode32_F5_3_1) {
  Bench b("RM9000", "ifm-rm8-rm9.eds");
  b.power_on();
  ASSERT_FALSE(b.rec.frames.empty());
  EXPECT_EQ(b.rec.frames[0], Frame::make(0x720, {0x00}));
  EXPECT_EQ(b.device->bitrate_kbit(), 125);
}

// CiA 305 / CiA 305: node-ID FFh = unconfigured: no boot-up, no SDO.
TEST(SimDeviceNmt, UnconfiguredNodeIsSilent_CiA305) {
  DeviceSpec spec;
  spec.node_id = 0xFF;
  Bench b("MC1-2800", "novotechnik-multiturn.eds", spec);
  b.power_on();
  EXPECT_TRUE(b.rec.frames.empty());
  EXPECT_EQ(b.device->node_id(), 0xFF);
  b.nmt(0x01);
  b.run_for(100ms);
  EXPECT_TRUE(b.rec.frames.empty());
}

// F§6.1.2-6.1.5, CiA 301 §7.3.2: start / stop / pre-op, node 0 = all.
TEST(SimDeviceNmt, Transitions_F6_1) {
  Bench b("RM9000", "ifm-rm8-rm9.eds");
  b.power_on();
  b.nmt(0x01, 32);
  EXPECT_EQ(b.device->nmt_state(), canopen::NmtState::operational);
  b.nmt(0x02, 0);
  EXPECT_EQ(b.device->nmt_state(), canopen::NmtState::stopped);
  b.nmt(0x80, 31);  // another node: ignored
  EXPECT_EQ(b.device->nmt_state(), canopen::NmtState::stopped);
  b.nmt(0x80, 32);
  EXPECT_EQ(b.device->nmt_state(), canopen::NmtState::pre_operational);
}

// F§6.1.5: after reset node the device boots again (boot-up, pre-op).
TEST(SimDeviceNmt, ResetNodeSendsBootUp_F6_1_5) {
  Bench b("RM9000", "ifm-rm8-rm9.eds");
  b.power_on();
  b.nmt(0x01, 32);
  b.rec.frames.clear();
  b.nmt(0x81, 32);
  ASSERT_EQ(b.rec.frames.size(), 1u);
  EXPECT_EQ(b.rec.frames[0], Frame::make(0x720, {0x00}));
  EXPECT_EQ(b.device->nmt_state(), canopen::NmtState::pre_operational);
}

// J§1.3.1 0x1F80: bit 3 set -> the sensor starts operational; after reset
// the unsaved value is gone (reset node restores the stored image).
TEST(SimDeviceNmt, AutostartBit3_J1_3_1) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  EXPECT_EQ(b.write_u32(0x1F80, 0, 0x08), Frame::make8(0x5FF, {0x60, 0x80, 0x1F, 0x00, 0, 0, 0, 0}));
  b.nmt(0x82, 0x7F);  // reset communication reloads the comm area: unsaved 0x1F80 is gone
  EXPECT_EQ(b.device->nmt_state(), canopen::NmtState::pre_operational);
  EXPECT_EQ(b.write_u32(0x1F80, 0, 0x08).data[0], 0x60);
  EXPECT_EQ(b.write_u32(0x1010, 2, 0x65766173).data[0], 0x60);  // save communication (J§1.10)
  b.nmt(0x82, 0x7F);
  EXPECT_EQ(b.device->nmt_state(), canopen::NmtState::operational);
}

// J§1.3.1 0x1017 (heartbeat exists although J§1.2.2 says "no").
TEST(SimDeviceNmt, HeartbeatPeriod_J1_3_1) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  EXPECT_EQ(b.write_u16(0x1017, 0, 100).data[0], 0x60);
  const std::size_t from = b.rec.frames.size();
  b.run_for(1000ms);
  const auto hb = b.frames_with_id(0x77F, from);
  ASSERT_EQ(hb.size(), 10u);
  for (const auto& f : hb) EXPECT_EQ(f, Frame::make(0x77F, {0x7F}));
  b.nmt(0x01, 0x7F);
  const std::size_t from2 = b.rec.frames.size();
  b.run_for(100ms);
  const auto hb2 = b.frames_with_id(0x77F, from2);
  ASSERT_EQ(hb2.size(), 1u);
  EXPECT_EQ(hb2[0], Frame::make(0x77F, {0x05}));
}

// CiA 301 §7.2.8.3.2.1: guarding replies toggle, state in bits 0-6.
TEST(SimDeviceNmt, NodeGuardingReplies_CiA301_7_2_8_3_2_1) {
  Bench b("MC1-2800", "novotechnik-multiturn.eds");
  b.power_on();
  Frame rtr = Frame::make(0x77F, {});
  rtr.flags = Frame::kFlagRtr;
  rtr.len = 1;
  const std::size_t from = b.rec.frames.size();
  b.deliver(rtr);
  b.deliver(rtr);
  const auto replies = b.frames_with_id(0x77F, from);
  ASSERT_EQ(replies.size(), 2u);
  EXPECT_EQ(replies[0], Frame::make(0x77F, {0x7F}));
  EXPECT_EQ(replies[1], Frame::make(0x77F, {0xFF}));
}

// E§4.1 0x1029/1, E§9.1 0x5000/0/0 "LifeGuarding error" (Info): life time
// expiry sends the EMCY and applies error behaviour 0 (-> pre-operational).
TEST(SimDeviceNmt, LifeGuardingLossMultiturn_E9_1) {
  Bench b("MC1-2800", "novotechnik-multiturn.eds");
  b.power_on();
  EXPECT_EQ(b.write_u16(0x100C, 0, 100).data[0], 0x60);
  EXPECT_EQ(b.write_u8(0x100D, 0, 3).data[0], 0x60);
  b.nmt(0x01, 0x7F);
  Frame rtr = Frame::make(0x77F, {});
  rtr.flags = Frame::kFlagRtr;
  rtr.len = 1;
  b.deliver(rtr);
  const std::size_t from = b.rec.frames.size();
  b.run_for(400ms);
  const auto emcy = b.frames_with_id(0xFF, from);
  ASSERT_EQ(emcy.size(), 1u);
  EXPECT_EQ(emcy[0], Frame::make8(0xFF, {0x00, 0x50, 0x00, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(b.device->nmt_state(), canopen::NmtState::pre_operational);
  const auto status = b.read(0x1002, 0);
  EXPECT_NE(Bench::value(status) & (1u << 24), 0u);  // E§10.1 bit 24
}

// J§1.2.1 / 0x1018: identity answered by SDO, vendor 0x182, product 0x0BE0.
TEST(SimDeviceNmt, IdentityBySdo_J1_2_1) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  EXPECT_EQ(b.read(0x1018, 1), Frame::make8(0x5FF, {0x43, 0x18, 0x10, 0x01, 0x82, 0x01, 0x00, 0x00}));
  EXPECT_EQ(b.read(0x1018, 2), Frame::make8(0x5FF, {0x43, 0x18, 0x10, 0x02, 0xE0, 0x0B, 0x00, 0x00}));
  EXPECT_EQ(b.read(0x1018, 4), Frame::make8(0x5FF, {0x43, 0x18, 0x10, 0x04, 0x78, 0x56, 0x34, 0x12}));
  EXPECT_EQ(b.read(0x1000, 0), Frame::make8(0x5FF, {0x43, 0x00, 0x10, 0x00, 0x96, 0x01, 0x01, 0x00}));
  const auto id = b.device->identity();
  EXPECT_EQ(id.vendor, 0x182u);
  EXPECT_EQ(id.product, 0x0BE0u);
  EXPECT_EQ(id.serial, 0x12345678u);
}

// J§1.9.1: 0x1002 bits 1-0 carry the NMT state.
TEST(SimDeviceNmt, StatusRegisterNmtBits_J1_9_1) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  EXPECT_EQ(Bench::value(b.read(0x1002, 0)) & 3u, 1u);
  b.nmt(0x01, 0x7F);
  EXPECT_EQ(Bench::value(b.read(0x1002, 0)) & 3u, 2u);
  b.nmt(0x02, 0x7F);
  b.nmt(0x80, 0x7F);
  EXPECT_EQ(Bench::value(b.read(0x1002, 0)) & 3u, 1u);
}

}  // namespace
}  // namespace cobridge::sim::test
