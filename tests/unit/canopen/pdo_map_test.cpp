#include "canopen/pdo_map.hpp"

#include <gtest/gtest.h>

#include <array>
#include <vector>

namespace cobridge::canopen {
namespace {

using can::Frame;

// Data types of the Novotechnik objects (J§1.3.2, E§4.2): positions INTEGER32,
// speeds INTEGER16; the state and alarm registers are unsigned.
PdoValueKind novotechnik_types(uint16_t index, uint8_t) {
  switch (index) {
    case 0x6004: case 0x6020: case 0x6030: return PdoValueKind::signed_integer;
    default: return PdoValueKind::unsigned_integer;
  }
}
// F§7.5: 0x6004 is UNSIGNED32 on ifm (limit-switch flags in bits 30/31), 0x6030/1 integer16.
PdoValueKind ifm_types(uint16_t index, uint8_t) {
  return index == 0x6030 ? PdoValueKind::signed_integer : PdoValueKind::unsigned_integer;
}
// Test objects in 0x2100 with sub-index 4 and 6 signed.
PdoValueKind test_types(uint16_t, uint8_t sub) {
  return (sub == 4 || sub == 6) ? PdoValueKind::signed_integer : PdoValueKind::unsigned_integer;
}

PdoLayout layout_of(std::vector<uint32_t> entries, const PdoTypeLookup& lookup = {},
                    PdoLimits limits = {}) {
  PdoLayoutResult r = build_pdo_layout(entries, lookup, limits);
  EXPECT_TRUE(r.ok()) << r.error.message() << ": " << r.message;
  return r.layout;
}

// J§1.7.2 / E§8.2 step 3: 0x60200120 is written by `23 00 1A 01 20 01 20 60`,
// 0x60300110 by `23 00 1A 02 10 01 30 60`: the entry is bytes 4-7, LE.
TEST(PdoMapEntry, J1_7_2_EntryMatchesSdoFrameOfManual) {
  const std::array<uint8_t, 8> sdo1{0x23, 0x00, 0x1A, 0x01, 0x20, 0x01, 0x20, 0x60};
  const std::array<uint8_t, 8> sdo2{0x23, 0x00, 0x1A, 0x02, 0x10, 0x01, 0x30, 0x60};
  const auto le32 = [](const std::array<uint8_t, 8>& d) {
    return uint32_t{d[4]} | uint32_t{d[5]} << 8 | uint32_t{d[6]} << 16 | uint32_t{d[7]} << 24;
  };
  EXPECT_EQ(make_mapping_entry(0x6020, 1, 32), le32(sdo1));
  EXPECT_EQ(make_mapping_entry(0x6030, 1, 16), le32(sdo2));
  const PdoMapEntry e = PdoMapEntry::from_raw(0x60300110);
  EXPECT_EQ(e.index, 0x6030);
  EXPECT_EQ(e.sub, 1);
  EXPECT_EQ(e.bits, 16);
  EXPECT_EQ(e.raw(), 0x60300110u);
}

// J§1.3.1 0x1A00 / J§1.7.2: 1-channel default payload `pos1 i32 | speed1 i16`.
TEST(PdoLayout, J1_7_2_OneChannelDefault) {
  const PdoLayout l = layout_of({0x60200120, 0x60300110}, novotechnik_types);
  ASSERT_EQ(l.field_count(), 2u);
  EXPECT_EQ(l.field(0).bit_offset, 0);
  EXPECT_EQ(l.field(0).bit_length, 32);
  EXPECT_EQ(l.field(0).kind, PdoValueKind::signed_integer);
  EXPECT_EQ(l.field(1).bit_offset, 32);
  EXPECT_EQ(l.field(1).bit_length, 16);
  EXPECT_EQ(l.frame_length(), 6);

  std::array<int64_t, 2> v{};
  EXPECT_EQ(l.decode(Frame::make(0x1FF, {0x34, 0x12, 0x00, 0x00, 0xFD, 0xFF}), v),
            PdoDecodeStatus::ok);
  EXPECT_EQ(v[0], 0x1234);
  EXPECT_EQ(v[1], -3);
  // A negative position (after a preset) reads as INTEGER32.
  EXPECT_EQ(l.decode(Frame::make(0x1FF, {0x18, 0xFC, 0xFF, 0xFF, 0x00, 0x00}), v),
            PdoDecodeStatus::ok);
  EXPECT_EQ(v[0], -1000);
}

// J§1.3.1 0x1A00/2 on 2-channel variants: `pos1 | pos2`, 8 bytes.
TEST(PdoLayout, J1_3_1_TwoChannelDefault) {
  const PdoLayout l = layout_of({0x60200120, 0x60200220}, novotechnik_types);
  EXPECT_EQ(l.frame_length(), 8);
  EXPECT_EQ(l.field(1).sub, 2);
  std::array<int64_t, 2> v{};
  ASSERT_EQ(l.decode(Frame::make8(0x1FF, {0xFF, 0x3F, 0, 0, 0xF0, 0x7F, 0, 0}), v),
            PdoDecodeStatus::ok);
  EXPECT_EQ(v[0], 0x3FFF);
  EXPECT_EQ(v[1], 0x7FF0);  // J§1.8 error position on channel 2
}

// E§4.1 0x1A00 and 0x1A01 defaults: 0x60200120, 0x60300110 (same payload as J).
TEST(PdoLayout, E4_1_DefaultTpdo1AndTpdo2) {
  // Both defaults are {0x60200120, 0x60300110}; 0x6020/1 is treated as the
  // INTEGER32 position (E§4.2: E's OD has no 0x6020).
  const PdoLayout l = layout_of({0x60200120, 0x60300110}, novotechnik_types);
  EXPECT_EQ(l.frame_length(), 6);
  std::array<int64_t, 2> v{};
  // E§9.1 overflow sentinel 0x7FFFFFF8 and underflow 0x80000008.
  ASSERT_EQ(l.decode(Frame::make(0x1FF, {0xF8, 0xFF, 0xFF, 0x7F, 0x00, 0x00}), v),
            PdoDecodeStatus::ok);
  EXPECT_EQ(v[0], 0x7FFFFFF8);
  ASSERT_EQ(l.decode(Frame::make(0x2FF, {0x08, 0x00, 0x00, 0x80, 0x00, 0x00}), v),
            PdoDecodeStatus::ok);
  EXPECT_EQ(v[0], -2147483640);
}

// E§8.2 mappable objects: 0x6004 (4), 0x6503 (2), 0x2002 (2) -> 8 bytes.
TEST(PdoLayout, E8_2_MappableObjectsFillEightBytes) {
  const PdoLayout l = layout_of({0x60040020, 0x65030010, 0x20020010}, novotechnik_types);
  EXPECT_EQ(l.total_bits(), 64);
  EXPECT_EQ(l.field(2).bit_offset, 48);
}

// F§7.3: 0x1A00/0 = 2 (ro), contents undocumented; F§7.5 0x6004 is UNSIGNED32
// and F§7.4 0x2104/0x2105 put limit-switch flags in bits 30/31.
TEST(PdoLayout, F7_3_IfmPositionIsUnsigned) {
  const PdoLayout l = layout_of({0x60040020, 0x60300110}, ifm_types);
  std::array<int64_t, 2> v{};
  ASSERT_EQ(l.decode(Frame::make(0x1A0, {0x34, 0x12, 0x00, 0xC0, 0xFE, 0xFF}), v),
            PdoDecodeStatus::ok);
  EXPECT_EQ(v[0], int64_t{0xC0001234});
  EXPECT_EQ(v[1], -2);
}

// J§1.7.2 / E§8.2: at most 5 mapping entries per PDO; SDO abort 0x06040042.
TEST(PdoLayout, J1_7_2_FiveEntryLimit) {
  PdoLimits limits;
  limits.max_entries = kNovotechnikMaxPdoEntries;
  const std::vector<uint32_t> five{0x63000108, 0x63000208, 0x64000108, 0x64000208, 0x65030010};
  EXPECT_TRUE(build_pdo_layout(five, {}, limits).ok());
  std::vector<uint32_t> six = five;
  six.push_back(0x65050010);
  const PdoLayoutResult r = build_pdo_layout(six, {}, limits);
  EXPECT_EQ(r.error, PdoMapErrc::too_many_entries);
  EXPECT_EQ(r.message, "6 entries, at most 5");
  EXPECT_EQ(sdo_abort_code(PdoMapErrc::too_many_entries), 0x06040042u);
  // Without the device limit CiA 301 allows it.
  EXPECT_TRUE(build_pdo_layout(six).ok());
}

// CiA 301 §7.4.8 / J§1.7.2 "maximum 8 bytes": more than 64 bits is rejected.
TEST(PdoLayout, CiA301_7_4_8_MoreThan64BitsRejected) {
  const PdoLayoutResult r = build_pdo_layout(std::vector<uint32_t>{0x60200120, 0x60200220, 0x60300110});
  EXPECT_EQ(r.error, PdoMapErrc::payload_too_long);
  EXPECT_EQ(r.message, "entry 3 (0x60300110): ends at bit 80, limit 64");
  EXPECT_EQ(sdo_abort_code(PdoMapErrc::payload_too_long), 0x06040042u);
  // Exactly 64 bits is fine.
  EXPECT_TRUE(build_pdo_layout(std::vector<uint32_t>{0x60200120, 0x60200220}).ok());
  PdoLimits small;
  small.max_bits = 48;
  EXPECT_FALSE(build_pdo_layout(std::vector<uint32_t>{0x60200120, 0x60200220}, {}, small).ok());
}

// CiA 301 §7.4.8: a mapping entry needs a length; >32 bits is not decoded here.
TEST(PdoLayout, CiA301_7_4_8_BadLengthsRejected) {
  PdoLayoutResult r = build_pdo_layout(std::vector<uint32_t>{0x60200120, 0x60300100});
  EXPECT_EQ(r.error, PdoMapErrc::zero_length);
  EXPECT_EQ(r.message, "entry 2 (0x60300100): length 0");
  EXPECT_EQ(sdo_abort_code(PdoMapErrc::zero_length), 0x06040041u);
  r = build_pdo_layout(std::vector<uint32_t>{0x20000040});
  EXPECT_EQ(r.error, PdoMapErrc::entry_too_long);
  EXPECT_EQ(r.error.category().name(), std::string("cobridge.pdo_map"));
  EXPECT_FALSE(r.error.message().empty());
}

// CiA 301 §7.4.8: 24-bit objects (INTEGER24) are little-endian and sign-extended.
TEST(PdoLayout, CiA301_7_4_8_Signed24Bit) {
  const PdoLayout l = layout_of({0x21000418, 0x21000518}, test_types);
  EXPECT_EQ(l.frame_length(), 6);
  std::array<int64_t, 2> v{};
  ASSERT_EQ(l.decode(Frame::make(0x181, {0xFE, 0xFF, 0xFF, 0xFE, 0xFF, 0xFF}), v),
            PdoDecodeStatus::ok);
  EXPECT_EQ(v[0], -2);        // signed
  EXPECT_EQ(v[1], 0xFFFFFE);  // unsigned
  Frame out;
  ASSERT_TRUE(l.encode(std::array<int64_t, 2>{-8388608, 0x123456}, out));
  EXPECT_EQ(out, Frame::make(0, {0x00, 0x00, 0x80, 0x56, 0x34, 0x12}));
}

// CiA 301 §7.4.8: objects are packed without padding, so 1-bit flags push the
// next object to odd bit offsets.
TEST(PdoLayout, CiA301_7_4_8_OddBitOffsets) {
  const PdoLayout l = layout_of({0x21000101, 0x21000410, 0x21000207}, test_types);
  EXPECT_EQ(l.field(1).bit_offset, 1);
  EXPECT_EQ(l.field(2).bit_offset, 17);
  EXPECT_EQ(l.frame_length(), 3);
  Frame out;
  ASSERT_TRUE(l.encode(std::array<int64_t, 3>{1, -1234, 0x55}, out));
  EXPECT_EQ(out, Frame::make(0, {0x5D, 0xF6, 0xAB}));
  std::array<int64_t, 3> v{};
  ASSERT_EQ(l.decode(out, v), PdoDecodeStatus::ok);
  EXPECT_EQ(v, (std::array<int64_t, 3>{1, -1234, 0x55}));

  const PdoLayout flags = layout_of({0x21000101, 0x21000201, 0x21000306, 0x21000418, 0x21000508},
                                    test_types);
  ASSERT_EQ(flags.frame_length(), 5);
  std::array<int64_t, 5> f{};
  ASSERT_EQ(flags.decode(Frame::make(0x181, {0xA9, 0xFE, 0xFF, 0xFF, 0x99}), f), PdoDecodeStatus::ok);
  EXPECT_EQ(f, (std::array<int64_t, 5>{1, 0, 0x2A, -2, 0x99}));
}

// CiA 301 §7.2.2.3: a shorter PDO is a length error (EMCY 0x8210) and not
// processed; a longer one is processed from its first bytes (EMCY 0x8220 case).
TEST(PdoLayout, CiA301_7_2_2_FrameLengthPolicy) {
  const PdoLayout l = layout_of({0x60200120, 0x60300110}, novotechnik_types);
  std::array<int64_t, 2> v{-7, -7};
  EXPECT_EQ(l.decode(Frame::make(0x1FF, {1, 0, 0, 0, 2}), v), PdoDecodeStatus::too_short);
  EXPECT_EQ(v[0], -7);  // untouched
  EXPECT_EQ(l.decode(Frame::make(0x1FF, {1, 0, 0, 0, 2, 0, 0xAA, 0xBB}), v),
            PdoDecodeStatus::ok_longer_frame);
  EXPECT_EQ(v[0], 1);
  EXPECT_EQ(v[1], 2);
  Frame rtr;
  rtr.flags = Frame::kFlagRtr;
  rtr.len = 6;
  EXPECT_EQ(l.decode(rtr, v), PdoDecodeStatus::remote_request);
  std::array<int64_t, 1> small{};
  EXPECT_EQ(l.decode(Frame::make(0x1FF, {1, 0, 0, 0, 2, 0}), small),
            PdoDecodeStatus::too_few_outputs);
}

// J§1.7.2 (the device side): encode produces the TPDO the simulator sends.
TEST(PdoLayout, J1_7_2_EncodeOneChannelDefault) {
  const PdoLayout l = layout_of({0x60200120, 0x60300110}, novotechnik_types);
  Frame out;
  out.id = 0x1FF;
  ASSERT_TRUE(l.encode(std::array<int64_t, 2>{0x3FFF, -3}, out));
  EXPECT_EQ(out, Frame::make(0x1FF, {0xFF, 0x3F, 0x00, 0x00, 0xFD, 0xFF}));
  // Out-of-range values are cut to the field width, as INTEGER16 storage would.
  ASSERT_TRUE(l.encode(std::array<int64_t, 2>{0, 0x12345}, out));
  EXPECT_EQ(out.data[4], 0x45);
  EXPECT_EQ(out.data[5], 0x23);
  EXPECT_FALSE(l.encode(std::array<int64_t, 1>{0}, out));
}

// CiA 301 §7.4.8 dummy mapping: indices 1..7 are data types that only reserve room.
TEST(PdoLayout, CiA301_7_4_8_DummyEntries) {
  const PdoLayout l = layout_of({0x00030010, 0x00050008, 0x60200120}, novotechnik_types);
  EXPECT_TRUE(l.field(0).dummy);
  EXPECT_EQ(l.field(0).kind, PdoValueKind::signed_integer);  // 0x0003 INTEGER16
  EXPECT_EQ(l.field(1).kind, PdoValueKind::unsigned_integer);  // 0x0005 UNSIGNED8
  EXPECT_FALSE(l.field(2).dummy);
  EXPECT_EQ(l.field(2).bit_offset, 24);
}

// CiA 301 §7.4.8: an empty mapping (sub 0 = 0) is valid and needs no data.
TEST(PdoLayout, CiA301_7_4_8_EmptyMapping) {
  const PdoLayout l = layout_of({});
  EXPECT_EQ(l.field_count(), 0u);
  EXPECT_EQ(l.frame_length(), 0);
  std::array<int64_t, 1> v{};
  EXPECT_EQ(l.decode(Frame::make(0x181, {}), v), PdoDecodeStatus::ok);
}

}  // namespace
}  // namespace cobridge::canopen
