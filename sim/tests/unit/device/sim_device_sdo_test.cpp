// SimDevice SDO server: the manuals' telegrams answered byte for byte, and
// the abort conditions of the write hooks.
#include "sim_bench.hpp"

namespace cobridge::sim::test {
namespace {

// E§7.1: set node-ID 0x40 -> confirmation; effective after reset communication.
TEST(SimDeviceSdo, NodeIdTelegram_E7_1) {
  Bench b("MC1-2800", "novotechnik-multiturn.eds");
  b.power_on();
  EXPECT_EQ(b.sdo({0x2F, 0x00, 0x20, 0x00, 0x40, 0x00, 0x00, 0x00}),
            Frame::make8(0x5FF, {0x60, 0x00, 0x20, 0x00, 0x00, 0x00, 0x00, 0x00}));
  EXPECT_EQ(b.device->node_id(), 0x7F);  // E§7.1: after a communication restart
  b.rec.frames.clear();
  b.nmt(0x82, 0x7F);
  EXPECT_EQ(b.device->node_id(), 0x40);
  ASSERT_FALSE(b.rec.frames.empty());
  EXPECT_EQ(b.rec.frames[0], Frame::make(0x740, {0x00}));
  // E§7.1: the predefined connection set follows, TPDO1 = 0x180 + node-ID.
  EXPECT_EQ(Bench::value(b.read(0x1800, 1)), 0x400001C0u);
  EXPECT_EQ(Bench::value(b.read(0x1014, 0)), 0xC0u);
}

// J§1.6.1: store all / restore all telegrams and their confirmations.
TEST(SimDeviceSdo, SaveLoadTelegrams_J1_6_1) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  EXPECT_EQ(b.sdo({0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65}),
            Frame::make8(0x5FF, {0x60, 0x10, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00}));
  EXPECT_EQ(b.sdo({0x23, 0x11, 0x10, 0x01, 0x6C, 0x6F, 0x61, 0x64}),
            Frame::make8(0x5FF, {0x60, 0x11, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00}));
  // J§1.10: the store object reads the manual's 0.
  EXPECT_EQ(Bench::value(b.read(0x1010, 1)), 0u);
}

// J§1.10: signatures only in pre-operational -> 0x08000022; a wrong
// signature -> 0x08000020 (J§1.6.3 "data transfer error").
TEST(SimDeviceSdo, StoreOnlyInPreOperational_J1_10) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  b.nmt(0x01, 0x7F);
  EXPECT_EQ(Bench::abort_code(b.write_u32(0x1010, 1, 0x65766173)), 0x08000022u);
  b.nmt(0x80, 0x7F);
  EXPECT_EQ(Bench::abort_code(b.write_u32(0x1010, 1, 0x12345678)), 0x08000020u);
}

// J§1.7.2: the mapping procedure disable -> clear -> entries -> count ->
// enable, each telegram confirmed; remapping while valid is refused.
TEST(SimDeviceSdo, MappingProcedure_J1_7_2) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  // Refused while the PDO is valid (0x40000180 + ID): "wrong state".
  EXPECT_EQ(Bench::abort_code(b.write_u8(0x1A00, 0, 0)), 0x08000022u);
  EXPECT_EQ(b.write_u32(0x1800, 1, 0xC00001FF), Frame::make8(0x5FF, {0x60, 0x00, 0x18, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(b.write_u8(0x1A00, 0, 0), Frame::make8(0x5FF, {0x60, 0x00, 0x1A, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(b.sdo({0x23, 0x00, 0x1A, 0x01, 0x20, 0x01, 0x20, 0x60}),
            Frame::make8(0x5FF, {0x60, 0x00, 0x1A, 0x01, 0, 0, 0, 0}));
  EXPECT_EQ(b.sdo({0x23, 0x00, 0x1A, 0x02, 0x10, 0x01, 0x30, 0x60}),
            Frame::make8(0x5FF, {0x60, 0x00, 0x1A, 0x02, 0, 0, 0, 0}));
  // Entry 3 names an object that cannot be mapped (0x6000 is not mappable).
  EXPECT_EQ(Bench::abort_code(b.write_u32(0x1A00, 3, 0x60000010)), 0x06040041u);
  EXPECT_EQ(b.write_u8(0x1A00, 0, 2), Frame::make8(0x5FF, {0x60, 0x00, 0x1A, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(b.write_u32(0x1800, 1, 0x400001FF), Frame::make8(0x5FF, {0x60, 0x00, 0x18, 0x01, 0, 0, 0, 0}));
  // Valid again: entries cannot change.
  EXPECT_EQ(Bench::abort_code(b.write_u32(0x1A00, 1, 0x60300110)), 0x08000022u);
}

// J§1.7.2, E§8.2: at most 5 entries and 8 bytes per PDO.
TEST(SimDeviceSdo, MappingLimits_J1_7_2) {
  Bench b("RFC-4800", "novotechnik-rfc4800-2ch.eds");
  b.power_on();
  ASSERT_EQ(b.write_u32(0x1800, 1, 0xC00001FF).data[0], 0x60);
  ASSERT_EQ(b.write_u8(0x1A00, 0, 0).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x1A00, 1, 0x60200120).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x1A00, 2, 0x60200220).data[0], 0x60);
  ASSERT_EQ(b.write_u32(0x1A00, 3, 0x60300110).data[0], 0x60);
  EXPECT_EQ(Bench::abort_code(b.write_u8(0x1A00, 0, 3)), 0x06040042u);  // 10 bytes
  EXPECT_EQ(Bench::abort_code(b.write_u8(0x1A00, 0, 6)), 0x06040042u);  // 6 entries
  EXPECT_EQ(b.write_u8(0x1A00, 0, 2).data[0], 0x60);
}

// E§8.2 step 1: the multiturn remaps only in pre-operational.
TEST(SimDeviceSdo, MultiturnMappingNeedsPreOperational_E8_2) {
  Bench b("MC1-2800", "novotechnik-multiturn.eds");
  b.power_on();
  b.nmt(0x01, 0x7F);
  ASSERT_EQ(b.write_u32(0x1800, 1, 0xC00001FF).data[0], 0x60);
  EXPECT_EQ(Bench::abort_code(b.write_u8(0x1A00, 0, 0)), 0x08000022u);
}

// J§1.4.2 / A.7.2: 0x6001 writable only with scaling on (0x6000 bit 2 = 1
// in J), at most 0x4000; 0x6002 follows. E§5.3 inverts the bit.
TEST(SimDeviceSdo, ScalingPolarityAndCoupling_J1_4_2_E5_3) {
  Bench j("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  j.power_on();
  EXPECT_EQ(Bench::abort_code(j.write_u32(0x6001, 0, 0x1000)), 0x08000022u);
  ASSERT_EQ(j.write_u16(0x6000, 0, 0x0004).data[0], 0x60);
  EXPECT_EQ(Bench::abort_code(j.write_u32(0x6001, 0, 0x8000)), 0x06090030u);
  EXPECT_EQ(j.write_u32(0x6001, 0, 0x1000).data[0], 0x60);
  EXPECT_EQ(Bench::value(j.read(0x6002, 0)), 0x1000u);

  Bench e("MC1-2800", "novotechnik-multiturn.eds");
  e.power_on();
  EXPECT_EQ(e.write_u32(0x6001, 0, 0x1000).data[0], 0x60);  // bit 2 = 0: on (E§5.3)
  EXPECT_EQ(Bench::value(e.read(0x6002, 0)), 0x1000u * 44u);
  ASSERT_EQ(e.write_u8(0x6000, 0, 0x04).data[0], 0x60);
  EXPECT_EQ(Bench::abort_code(e.write_u32(0x6001, 0, 0x2000)), 0x08000022u);
}

// E§4.1: 0x6020/1 is a hidden read-only alias of 0x6004 on E.
TEST(SimDeviceSdo, MultiturnPositionAlias_C3) {
  DeviceSpec spec;
  spec.motion = "constant:0";
  Bench b("MC1-2800", "novotechnik-multiturn.eds", spec);
  b.power_on();
  b.run_for(2ms);
  EXPECT_EQ(b.read(0x6020, 1).data[0], 0x43);
  EXPECT_EQ(Bench::value(b.read(0x6020, 1)), Bench::value(b.read(0x6004, 0)));
  EXPECT_EQ(Bench::abort_code(b.write_u32(0x6020, 1, 5)), 0x06010002u);
}

// F§7.4, F§7.3, F§7.5 0x6200: 0x6200 <-> 0x1800/5 and the read-only mirror 0x2200;
// 0x2101..0x2103 twins of 0x6001..0x6003; 0x4000 refuses every value.
TEST(SimDeviceSdo, IfmAliases_F7_4) {
  Bench b("RM9000", "ifm-rm8-rm9.eds");
  b.power_on();
  ASSERT_EQ(b.write_u16(0x6200, 0, 250).data[0], 0x60);
  EXPECT_EQ(Bench::value(b.read(0x1800, 5)), 250u);
  EXPECT_EQ(Bench::value(b.read(0x2200, 0)), 250u);
  ASSERT_EQ(b.write_u32(0x1800, 5, 20).data[0], 0x60);
  EXPECT_EQ(Bench::value(b.read(0x6200, 0)) & 0xFFFFu, 20u);
  EXPECT_EQ(Bench::abort_code(b.write_u16(0x2200, 0, 1)), 0x06010002u);
  ASSERT_EQ(b.write_u32(0x2101, 0, 1024).data[0], 0x60);
  EXPECT_EQ(Bench::value(b.read(0x6001, 0)), 1024u);
  ASSERT_EQ(b.write_u32(0x6003, 0, 77).data[0], 0x60);
  EXPECT_EQ(Bench::value(b.read(0x2103, 0)), 77u);
  EXPECT_EQ(Bench::abort_code(b.write_u32(0x2101, 0, 8192)), 0x06090030u);  // above physical
  EXPECT_NE(Bench::abort_code(b.write_u32(0x4000, 0, 0x12345678)), 0u);
  EXPECT_NE(Bench::abort_code(b.write_u32(0x4000, 0, 0)), 0u);
}

// F§7.4 0x3000: node-ID = value + 1; effective after reset (F§6.3.2).
TEST(SimDeviceSdo, IfmNodeNumberPlusOne_F7_4) {
  Bench b("RM9000", "ifm-rm8-rm9.eds");
  b.power_on();
  EXPECT_EQ(Bench::value(b.read(0x3000, 0)) & 0xFFu, 0x1Fu);
  ASSERT_EQ(b.write_u8(0x3000, 0, 0x04).data[0], 0x60);
  b.nmt(0x82, 32);
  EXPECT_EQ(b.device->node_id(), 5);
}

// J§1.6.3: write read-only / read write-only / missing objects.
TEST(SimDeviceSdo, AbortCodes_J1_6_3) {
  Bench b("MC1-2800", "novotechnik-multiturn.eds");
  b.power_on();
  EXPECT_EQ(Bench::abort_code(b.write_u32(0x1000, 0, 1)), 0x06010002u);
  EXPECT_EQ(Bench::abort_code(b.read(0x2100, 0)), 0x06010001u);
  EXPECT_EQ(Bench::abort_code(b.read(0x5555, 0)), 0x06020000u);
  EXPECT_EQ(Bench::abort_code(b.read(0x1018, 9)), 0x06090011u);
  EXPECT_EQ(Bench::abort_code(b.write_u8(0x2000, 0, 0)), 0x06090030u);
  EXPECT_EQ(Bench::abort_code(b.write_u16(0x2001, 0, 300)), 0x06090030u);
  EXPECT_EQ(Bench::abort_code(b.write_u8(0x1800, 2, 253)), 0x06090030u);  // no RTR types on E
}

// cobridge-sim `abort-sdo`: the next initiate request for the object gets a
// CiA 301 §7.2.4.3.17 abort (80 | index | sub | code, little-endian) instead
// of its answer; one request only, other objects are served meanwhile.
TEST(SimDeviceSdo, InjectedAbortAnswersOneRequestForTheObject) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  b.device->abort_sdo(0x1800, 0x08000020);
  EXPECT_EQ(b.read(0x1018, 4).data[0], 0x43);  // another object: served (expedited upload, 4 bytes)
  EXPECT_EQ(b.write_u32(0x1800, 5, 100), Frame::make8(0x5FF, {0x80, 0x00, 0x18, 0x05, 0x20, 0x00, 0x00, 0x08}));
  EXPECT_EQ(b.write_u32(0x1800, 1, 0xC00001FF), Frame::make8(0x5FF, {0x60, 0x00, 0x18, 0x01, 0, 0, 0, 0}));
  b.device->abort_sdo(0x1017, 0x06090030);
  EXPECT_EQ(Bench::abort_code(b.read(0x1017, 0)), 0x06090030u);  // an upload too
  EXPECT_EQ(Bench::abort_code(b.read(0x1017, 0)), 0u);
}

// cobridge-sim `ignore-sdo`: the next n initiate requests for the object get
// no answer (the master's SDO timeout, CiA 301 §7.2.4.3: a lost request);
// the one after is served.
TEST(SimDeviceSdo, IgnoredRequestsGetNoAnswer) {
  Bench b("RFC-4800", "novotechnik-rfc4800-1ch.eds");
  b.power_on();
  b.device->ignore_sdo(0x1800, 2);
  EXPECT_EQ(b.read(0x1800, 5), Frame{});
  EXPECT_EQ(b.read(0x1018, 4).data[0], 0x43);  // another object: served
  EXPECT_EQ(b.read(0x1800, 5), Frame{});
  EXPECT_EQ(b.read(0x1800, 5).data[0], 0x4B);  // served again (expedited upload, 2 bytes)
}

}  // namespace
}  // namespace cobridge::sim::test
