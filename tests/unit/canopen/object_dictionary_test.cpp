// Unit tests for canopen::ObjectDictionary: setup checks, the SDO-path checks
// (existence, access, length, limits, hooks) with their CiA 301 abort codes,
// and the device-model typed accessors.
#include "canopen/object_dictionary.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace cobridge::canopen {
namespace {

using Bytes = std::vector<uint8_t>;

Bytes read_bytes(ObjectDictionary& od, uint16_t index, uint8_t sub, uint32_t* code = nullptr) {
  std::array<uint8_t, 64> buf{};
  const ReadResult r = od.read(index, sub, buf);
  if (code != nullptr) *code = r.abort_code;
  return Bytes(buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(r.size));
}

uint32_t write_bytes(ObjectDictionary& od, uint16_t index, uint8_t sub, const Bytes& data) {
  return od.write(index, sub, data);
}

// A subset of the rotary sensor's dictionary (J§1.3.1, J§1.3.2, J§1.3.3) plus
// E's write-only Bool objects (E§4.3 0x2100).
class OdTest : public ::testing::Test {
 protected:
  void SetUp() override { build(od_); }

  static void build(ObjectDictionary& od) {
    auto add = [&od](const EntryDef& d) { ASSERT_FALSE(od.insert(d)) << d.name; };
    add({.index = 0x6000, .sub = 0, .type = DataType::kUnsigned16, .access = Access::kRw,
         .name = "operating parameter", .value = 0});
    add({.index = 0x1000, .sub = 0, .type = DataType::kUnsigned32, .access = Access::kConst,
         .name = "device type", .value = 0x00010196U});
    add({.index = 0x1008, .sub = 0, .type = DataType::kVisibleString, .access = Access::kConst,
         .name = "manufacturer device name", .capacity = 32, .text = "RFC-4801-214-614-511"});
    add({.index = 0x1018, .sub = 0, .type = DataType::kUnsigned8, .access = Access::kRo,
         .name = "identity: number of entries", .value = 4});
    add({.index = 0x1018, .sub = 1, .type = DataType::kUnsigned32, .access = Access::kRo,
         .name = "vendor-ID", .value = 0x182U});
    add({.index = 0x2000, .sub = 0, .type = DataType::kUnsigned8, .access = Access::kRw,
         .name = "node-ID", .value = 0x7F, .low = 1, .high = 127});
    add({.index = 0x2100, .sub = 0, .type = DataType::kBoolean, .access = Access::kWo,
         .name = "position error reset", .value = 1});
    add({.index = 0x6001, .sub = 0, .type = DataType::kUnsigned32, .access = Access::kRw,
         .name = "measuring units per revolution", .value = 0x4000U, .low = 1, .high = 0x4000U});
    add({.index = 0x6002, .sub = 0, .type = DataType::kUnsigned32, .access = Access::kRw,
         .name = "total measuring range", .value = 0x4000U});
    add({.index = 0x6010, .sub = 0, .type = DataType::kUnsigned8, .access = Access::kRo,
         .name = "preset: channels", .value = 1});
    add({.index = 0x6010, .sub = 1, .type = DataType::kInteger32, .access = Access::kRw,
         .name = "preset ch1", .value = 0});
    add({.index = 0x6020, .sub = 1, .type = DataType::kInteger32, .access = Access::kRo, .pdo_mappable = true,
         .name = "position ch1", .value = 0});
    add({.index = 0x6030, .sub = 1, .type = DataType::kInteger16, .access = Access::kRo, .pdo_mappable = true,
         .name = "speed ch1", .value = -2, .low = -100, .high = 100});
    for (uint8_t s = 1; s <= 4; ++s)
      add({.index = 0x1010, .sub = s, .type = DataType::kUnsigned32, .access = Access::kRw,
           .name = "store parameters", .value = 0});
  }

  ObjectDictionary od_;
};

// --- setup ------------------------------------------------------------------

// CiA 301 §7.4.1: entries are addressed by 16-bit index and 8-bit sub-index.
// Insertion order must not matter; every entry is found by binary search.
TEST(ObjectDictionary, CiA301_7_4_1_EntriesFoundWhateverTheInsertionOrder) {
  std::vector<uint32_t> keys;
  for (uint32_t i = 0; i < 300; ++i) keys.push_back(((0x1000U + i * 37U) << 8U) | (i % 5U));
  std::mt19937 rng(7);
  std::shuffle(keys.begin(), keys.end(), rng);
  ObjectDictionary od;
  for (uint32_t k : keys) {
    const auto index = static_cast<uint16_t>(k >> 8U);
    const auto sub = static_cast<uint8_t>(k & 0xFFU);
    ASSERT_FALSE(od.insert({.index = index, .sub = sub, .type = DataType::kUnsigned32, .value = k}));
  }
  EXPECT_EQ(od.entry_count(), keys.size());
  for (uint32_t k : keys) {
    const auto v = od.get_u32(static_cast<uint16_t>(k >> 8U), static_cast<uint8_t>(k & 0xFFU));
    ASSERT_TRUE(v.has_value());
    EXPECT_EQ(*v, k);
  }
  EXPECT_FALSE(od.contains(0x1000, 1));
  EXPECT_TRUE(od.contains_index(0x1025));
  EXPECT_FALSE(od.contains_index(0x1001));
}

TEST_F(OdTest, CiA301_7_4_1_DuplicateEntryRejected) {
  const std::error_code ec = od_.insert({.index = 0x1000, .sub = 0, .type = DataType::kUnsigned32});
  EXPECT_EQ(ec, OdError::kDuplicateEntry);
  EXPECT_STREQ(ec.category().name(), "cobridge.object_dictionary");
  EXPECT_FALSE(ec.message().empty());
}

// CiA 301 §7.1 data types: a default must fit its type; no silent truncation.
TEST(ObjectDictionary, CiA301_7_1_DefaultsAndLimitsMustFitTheType) {
  ObjectDictionary od;
  EXPECT_EQ(od.insert({.index = 0x2000, .type = DataType::kUnsigned8, .value = 256}), OdError::kValueDoesNotFit);
  EXPECT_EQ(od.insert({.index = 0x2001, .type = DataType::kUnsigned16, .value = -1}), OdError::kValueDoesNotFit);
  EXPECT_EQ(od.insert({.index = 0x2002, .type = DataType::kInteger8, .value = 128}), OdError::kValueDoesNotFit);
  EXPECT_EQ(od.insert({.index = 0x2003, .type = DataType::kBoolean, .value = 2}), OdError::kValueDoesNotFit);
  EXPECT_EQ(od.insert({.index = 0x2004, .type = DataType::kUnsigned8, .value = 1.5}), OdError::kValueDoesNotFit);
  EXPECT_EQ(od.insert({.index = 0x2005, .type = DataType::kInteger24, .value = 0, .low = -8388609}),
            OdError::kValueDoesNotFit);
  EXPECT_FALSE(od.insert({.index = 0x2006, .type = DataType::kInteger8, .value = -128}));
  EXPECT_FALSE(od.insert({.index = 0x2007, .type = DataType::kInteger24, .value = -8388608}));
  EXPECT_EQ(od.insert({.index = 0x2008, .type = DataType::kUnsigned8, .value = 5, .low = 10, .high = 1}),
            OdError::kBadLimits);
  EXPECT_EQ(od.insert({.index = 0x2009, .type = DataType::kUnsigned8, .value = 0, .low = 1, .high = 127}),
            OdError::kBadLimits);
  EXPECT_EQ(od.insert({.index = 0x200A, .type = DataType::kVisibleString, .capacity = 3, .text = "abcd"}),
            OdError::kStringTooLong);
  EXPECT_EQ(od.insert({.index = 0x200B, .type = static_cast<DataType>(0x000C)}), OdError::kUnsupportedType);
  EXPECT_EQ(od.entry_count(), 2U);
}

TEST_F(OdTest, SetHooksOnMissingEntryIsAnError) {
  EXPECT_EQ(od_.set_hooks(0x3000, 0, Hooks{}), OdError::kNoSuchEntry);
  EXPECT_EQ(od_.set_hooks(0x3000, Hooks{}), OdError::kNoSuchEntry);
  EXPECT_FALSE(od_.set_hooks(0x1010, Hooks{}));
}

TEST_F(OdTest, InfoReportsMetadata) {
  const auto pos = od_.info(0x6020, 1);
  ASSERT_TRUE(pos);
  EXPECT_EQ(pos->type, DataType::kInteger32);
  EXPECT_EQ(pos->access, Access::kRo);
  EXPECT_TRUE(pos->pdo_mappable);
  EXPECT_EQ(pos->size, 4U);
  EXPECT_EQ(pos->name, "position ch1");
  const auto name = od_.info(0x1008, 0);
  ASSERT_TRUE(name);
  EXPECT_TRUE(name->is_string);
  EXPECT_EQ(name->size, 20U);
  EXPECT_EQ(name->capacity, 32U);
  EXPECT_EQ(od_.max_value_size(), 32U);
  EXPECT_FALSE(od_.info(0x6020, 2));
}

// --- SDO read path ------------------------------------------------------------

// J§1.3.1 0x1000 = 0x00010196, sent little-endian (CiA 301 §7.1.4 basic data
// type encoding).
TEST_F(OdTest, J_1_3_1_ReadDeviceTypeLittleEndian) {
  uint32_t code = 1;
  EXPECT_EQ(read_bytes(od_, 0x1000, 0, &code), (Bytes{0x96, 0x01, 0x01, 0x00}));
  EXPECT_EQ(code, 0U);
}

// CiA 301 §7.1.4: signed values are two's complement in their own width.
TEST(ObjectDictionary, CiA301_7_1_4_SignedValuesEncodedInTheirWidth) {
  ObjectDictionary od;
  ASSERT_FALSE(od.insert({.index = 0x2000, .type = DataType::kInteger24, .value = -1}));
  ASSERT_FALSE(od.insert({.index = 0x2001, .type = DataType::kInteger16, .value = -2}));
  ASSERT_FALSE(od.insert({.index = 0x2002, .type = DataType::kUnsigned24, .value = 0x123456}));
  ASSERT_FALSE(od.insert({.index = 0x2003, .type = DataType::kReal32, .value = 1.0f}));
  EXPECT_EQ(read_bytes(od, 0x2000, 0), (Bytes{0xFF, 0xFF, 0xFF}));
  EXPECT_EQ(read_bytes(od, 0x2001, 0), (Bytes{0xFE, 0xFF}));
  EXPECT_EQ(read_bytes(od, 0x2002, 0), (Bytes{0x56, 0x34, 0x12}));
  EXPECT_EQ(read_bytes(od, 0x2003, 0), (Bytes{0x00, 0x00, 0x80, 0x3F}));
  EXPECT_EQ(od.get_i32(0x2000, 0), -1);
}

// J§1.6.3 / E§7.3 codes: object missing, sub-index missing, write-only.
TEST_F(OdTest, J_1_6_3_ReadAbortCodes) {
  uint32_t code = 0;
  read_bytes(od_, 0x3000, 0, &code);
  EXPECT_EQ(code, 0x06020000U);
  read_bytes(od_, 0x1018, 5, &code);
  EXPECT_EQ(code, 0x06090011U);
  read_bytes(od_, 0x2100, 0, &code);  // E§4.3 0x2100 is write-only
  EXPECT_EQ(code, 0x06010001U);
}

TEST_F(OdTest, ReadIntoTooSmallBufferIsOutOfMemory) {
  std::array<uint8_t, 8> small{};
  const ReadResult r = od_.read(0x1008, 0, small);
  EXPECT_EQ(r.abort_code, 0x05040005U);
  EXPECT_EQ(r.size, 0U);
}

TEST_F(OdTest, J_1_3_1_ReadStringReturnsCurrentLengthNotCapacity) {
  const Bytes b = read_bytes(od_, 0x1008, 0);
  EXPECT_EQ(std::string(b.begin(), b.end()), "RFC-4801-214-614-511");
}

// --- SDO write path -----------------------------------------------------------

// J§1.6.3 0x06010002: const (0x1000) and ro (0x1018/1) objects refuse writes.
TEST_F(OdTest, J_1_6_3_WriteOfReadOnlyAndConstRefused) {
  EXPECT_EQ(write_bytes(od_, 0x1000, 0, {1, 2, 3, 4}), 0x06010002U);
  EXPECT_EQ(write_bytes(od_, 0x1018, 1, {1, 2, 3, 4}), 0x06010002U);
  EXPECT_EQ(write_bytes(od_, 0x3000, 0, {1}), 0x06020000U);
  EXPECT_EQ(write_bytes(od_, 0x1018, 9, {1}), 0x06090011U);
  EXPECT_EQ(od_.get_u32(0x1000, 0), 0x00010196U);
}

// CiA 301 §7.2.4.3.17: 0x06070012 length too high, 0x06070013 too low.
TEST_F(OdTest, CiA301_7_2_4_3_17_LengthMustMatchNumericType) {
  EXPECT_EQ(write_bytes(od_, 0x6000, 0, {1, 0, 0, 0}), 0x06070012U);
  EXPECT_EQ(write_bytes(od_, 0x6001, 0, {1}), 0x06070013U);
  EXPECT_EQ(write_bytes(od_, 0x6000, 0, {0x04, 0x00}), 0U);
  EXPECT_EQ(od_.get_u16(0x6000, 0), 0x0004);
}

// J§1.3.3 0x2000 node-ID range 1..127; J§1.6.3 lists only 0x06090030.
TEST_F(OdTest, J_1_3_3_NodeIdOutsideRangeIsValueExceeded) {
  EXPECT_EQ(write_bytes(od_, 0x2000, 0, {0}), 0x06090030U);
  EXPECT_EQ(write_bytes(od_, 0x2000, 0, {128}), 0x06090030U);
  EXPECT_EQ(od_.get_u8(0x2000, 0), 0x7F);
  EXPECT_EQ(write_bytes(od_, 0x2000, 0, {0x40}), 0U);
  EXPECT_EQ(od_.get_u8(0x2000, 0), 0x40);
}

// CiA 301 §7.2.4.3.17: with the option on, 0x06090031 too high / 0x06090032
// too low, compared in the entry's own signedness.
TEST(ObjectDictionary, CiA301_7_2_4_3_17_SpecificRangeAbortsWhenEnabled) {
  ObjectDictionary od(ObjectDictionary::Options{.specific_range_aborts = true});
  ASSERT_FALSE(od.insert({.index = 0x2000, .type = DataType::kInteger16, .value = 0, .low = -100, .high = 100}));
  ASSERT_FALSE(od.insert({.index = 0x2001, .type = DataType::kReal32, .value = 0.0f, .low = -1.5f, .high = 2.5f}));
  EXPECT_EQ(write_bytes(od, 0x2000, 0, {0x9B, 0xFF}), 0x06090032U);  // -101
  EXPECT_EQ(write_bytes(od, 0x2000, 0, {0x65, 0x00}), 0x06090031U);  // 101
  EXPECT_EQ(write_bytes(od, 0x2000, 0, {0x9C, 0xFF}), 0U);           // -100
  EXPECT_EQ(od.get_i16(0x2000, 0), -100);
  EXPECT_EQ(write_bytes(od, 0x2001, 0, {0x00, 0x00, 0x40, 0x40}), 0x06090031U);  // 3.0f
  EXPECT_EQ(write_bytes(od, 0x2001, 0, {0x00, 0x00, 0x00, 0xC0}), 0x06090032U);  // -2.0f
  EXPECT_EQ(write_bytes(od, 0x2001, 0, {0x00, 0x00, 0x00, 0x40}), 0U);           // 2.0f
  EXPECT_EQ(od.get_f32(0x2001, 0), 2.0f);
}

// CiA 301 §7.1.4.2: BOOLEAN is 0 or 1.
TEST_F(OdTest, CiA301_7_1_4_BooleanAcceptsOnlyZeroOrOne) {
  EXPECT_EQ(write_bytes(od_, 0x2100, 0, {2}), 0x06090030U);
  EXPECT_EQ(write_bytes(od_, 0x2100, 0, {0}), 0U);
  EXPECT_EQ(od_.get_bool(0x2100, 0), false);
}

TEST(ObjectDictionary, StringWritesUpToCapacity) {
  ObjectDictionary od;
  ASSERT_FALSE(od.insert({.index = 0x2F00, .type = DataType::kVisibleString, .capacity = 8, .text = "abc"}));
  EXPECT_EQ(write_bytes(od, 0x2F00, 0, {'h', 'e', 'l', 'l', 'o'}), 0U);
  EXPECT_EQ(od.get_string(0x2F00, 0), "hello");
  EXPECT_EQ(write_bytes(od, 0x2F00, 0, Bytes(9, 'x')), 0x06070012U);
  EXPECT_EQ(od.get_string(0x2F00, 0), "hello");
  EXPECT_EQ(write_bytes(od, 0x2F00, 0, {}), 0U);
  EXPECT_EQ(od.get_string(0x2F00, 0), "");
}

// --- hooks ----------------------------------------------------------------------

// J§1.4.2 / E§5.4: "Writing is only possible if scaling (0x6000 / Bit 2) is
// on. Changes of this object also changes object 0x6002." A hook vetoes with
// 0x08000022 ("wrong state", J§1.6.3) and after_write couples 0x6002.
TEST_F(OdTest, J_1_4_2_HookVetoesScalingWriteWhenScalingOff) {
  ASSERT_FALSE(od_.set_hooks(
      0x6001, 0,
      Hooks{.on_read = nullptr,
            .on_write = [this](const WriteRequest&) -> uint32_t {
              return (od_.get_u16(0x6000, 0).value_or(0) & 0x04U) != 0 ? 0U : 0x08000022U;
            },
            .after_write = [this](uint16_t, uint8_t) {
              (void)od_.set_u32(0x6002, 0, od_.get_u32(0x6001, 0).value_or(0));
            }}));
  EXPECT_EQ(write_bytes(od_, 0x6001, 0, {0x00, 0x10, 0x00, 0x00}), 0x08000022U);
  EXPECT_EQ(od_.get_u32(0x6001, 0), 0x4000U);
  EXPECT_EQ(od_.get_u32(0x6002, 0), 0x4000U);

  ASSERT_EQ(od_.set_u16(0x6000, 0, 0x0004), 0U);
  EXPECT_EQ(write_bytes(od_, 0x6001, 0, {0x00, 0x10, 0x00, 0x00}), 0U);
  EXPECT_EQ(od_.get_u32(0x6001, 0), 0x1000U);
  EXPECT_EQ(od_.get_u32(0x6002, 0), 0x1000U);
}

// Limits are checked before the hook runs (the hook sees only valid values).
TEST_F(OdTest, LimitsCheckedBeforeHook) {
  int calls = 0;
  ASSERT_FALSE(od_.set_hooks(0x6001, 0, Hooks{.on_read = nullptr, .on_write = [&calls](const WriteRequest&) {
                                                ++calls;
                                                return 0U;
                                              }, .after_write = nullptr}));
  EXPECT_EQ(write_bytes(od_, 0x6001, 0, {0x01, 0x40, 0x00, 0x00}), 0x06090030U);  // 0x4001 > high
  EXPECT_EQ(calls, 0);
}

// J§1.6.1 / J§1.10: 'save' 0x65766173 on 0x1010/1..4. A per-index hook sees
// every sub-index; a wrong signature is refused with 0x08000020; the object
// keeps reading 0 (J§1.3.1 default; J§1.10).
TEST_F(OdTest, J_1_6_1_SaveSignatureHandledByPerIndexHook) {
  std::vector<std::pair<uint8_t, uint32_t>> saves;
  ASSERT_FALSE(od_.set_hooks(
      0x1010, Hooks{.on_read = nullptr,
                    .on_write = [&saves](const WriteRequest& w) -> uint32_t {
                      if (w.as_unsigned() != 0x65766173U) return 0x08000020U;
                      saves.emplace_back(w.sub, static_cast<uint32_t>(w.as_unsigned()));
                      return 0U;
                    },
                    .after_write = [this](uint16_t index, uint8_t sub) { (void)od_.set_u32(index, sub, 0); }}));
  EXPECT_EQ(write_bytes(od_, 0x1010, 1, {0x73, 0x61, 0x76, 0x65}), 0U);
  EXPECT_EQ(write_bytes(od_, 0x1010, 4, {0x73, 0x61, 0x76, 0x65}), 0U);
  EXPECT_EQ(write_bytes(od_, 0x1010, 2, {0x6C, 0x6F, 0x61, 0x64}), 0x08000020U);
  ASSERT_EQ(saves.size(), 2U);
  EXPECT_EQ(saves[0], (std::pair<uint8_t, uint32_t>{1, 0x65766173U}));
  EXPECT_EQ(saves[1].first, 4);
  EXPECT_EQ(read_bytes(od_, 0x1010, 1), (Bytes{0, 0, 0, 0}));
}

// An on_read hook refreshes the value before it is copied out (the device
// model computes the position on demand) or vetoes the read.
TEST_F(OdTest, OnReadHookRefreshesOrVetoes) {
  int32_t position = -5;
  bool fail = false;
  ASSERT_FALSE(od_.set_hooks(0x6020, 1, Hooks{.on_read = [&](uint16_t, uint8_t) -> uint32_t {
                                                if (fail) return 0x08000000U;
                                                return od_.set_i32(0x6020, 1, position);
                                              },
                                              .on_write = nullptr, .after_write = nullptr}));
  EXPECT_EQ(read_bytes(od_, 0x6020, 1), (Bytes{0xFB, 0xFF, 0xFF, 0xFF}));
  position = 0x01020304;
  EXPECT_EQ(read_bytes(od_, 0x6020, 1), (Bytes{0x04, 0x03, 0x02, 0x01}));
  fail = true;
  uint32_t code = 0;
  EXPECT_TRUE(read_bytes(od_, 0x6020, 1, &code).empty());
  EXPECT_EQ(code, 0x08000000U);
}

TEST_F(OdTest, WriteRequestDecodesSignedValues) {
  int64_t seen = 0;
  ASSERT_FALSE(od_.set_hooks(0x6010, 1, Hooks{.on_read = nullptr,
                                              .on_write = [&seen](const WriteRequest& w) {
                                                seen = w.as_signed();
                                                return 0U;
                                              },
                                              .after_write = nullptr}));
  EXPECT_EQ(write_bytes(od_, 0x6010, 1, {0x18, 0xFC, 0xFF, 0xFF}), 0U);
  EXPECT_EQ(seen, -1000);
  EXPECT_EQ(od_.get_i32(0x6010, 1), -1000);
}

// --- typed accessors -------------------------------------------------------------

TEST_F(OdTest, TypedGettersWidenButNeverNarrow) {
  EXPECT_EQ(od_.get_u32(0x6000, 0), 0U);         // UNSIGNED16 read as u32
  EXPECT_EQ(od_.get_u8(0x6000, 0), std::nullopt);  // would narrow
  EXPECT_EQ(od_.get_i32(0x6000, 0), std::nullopt);  // wrong signedness
  EXPECT_EQ(od_.get_i16(0x6030, 1), -2);
  EXPECT_EQ(od_.get_i64(0x6030, 1), -2);
  EXPECT_EQ(od_.get_raw(0x6030, 1), 0xFFFEU);
  EXPECT_EQ(od_.get_u32(0x1008, 0), std::nullopt);
  EXPECT_EQ(od_.get_string(0x1008, 0), "RFC-4801-214-614-511");
  EXPECT_EQ(od_.get_u32(0x3000, 0), std::nullopt);
}

// The device model updates read-only objects and is not bound by the SDO
// limits (0x6030/1 limits are -100..100 for SDO writes only).
TEST_F(OdTest, TypedSettersBypassAccessAndLimitsButCheckTheType) {
  EXPECT_EQ(od_.set_i32(0x6020, 1, -123456), 0U);
  EXPECT_EQ(od_.get_i32(0x6020, 1), -123456);
  EXPECT_EQ(od_.set_i16(0x6030, 1, 1000), 0U);
  EXPECT_EQ(od_.get_i16(0x6030, 1), 1000);
  EXPECT_EQ(od_.set_u32(0x6000, 0, 0x10000U), 0x06090030U);  // does not fit UNSIGNED16
  EXPECT_EQ(od_.set_u16(0x6000, 0, 0xFFFF), 0U);
  EXPECT_EQ(od_.set_i32(0x6000, 0, 1), 0x06070010U);  // signed setter on unsigned entry
  EXPECT_EQ(od_.set_i32(0x6030, 1, 40000), 0x06090030U);
  EXPECT_EQ(od_.set_u32(0x3000, 0, 1), 0x06020000U);
  EXPECT_EQ(od_.set_u32(0x1018, 7, 1), 0x06090011U);
  EXPECT_EQ(od_.set_string(0x1008, 0, "MC1-2832-A7F-614-511"), 0U);
  EXPECT_EQ(od_.get_string(0x1008, 0), "MC1-2832-A7F-614-511");
  EXPECT_EQ(od_.set_string(0x1008, 0, std::string(33, 'x')), 0x06070012U);
  EXPECT_EQ(od_.set_bool(0x2100, 0, false), 0U);
  EXPECT_EQ(od_.get_bool(0x2100, 0), false);
  EXPECT_EQ(od_.set_bool(0x6000, 0, true), 0x06070010U);
}

}  // namespace
}  // namespace cobridge::canopen
