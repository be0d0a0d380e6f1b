// SDO abort codes: wire values, texts and the std::error_code plumbing.
#include "canopen/sdo_abort.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace cobridge::canopen {
namespace {

bool contains(std::string_view hay, std::string_view needle) { return hay.find(needle) != std::string_view::npos; }

// CiA 301 §7.2.4.3.17 table 22: every code the spec defines, with its value.
TEST(SdoAbort, CiA301_7_2_4_3_17_EnumValuesAreTheWireCodes) {
  struct Row {
    SdoAbort e;
    uint32_t wire;
  };
  const Row rows[] = {
      {SdoAbort::kToggleBitNotAlternated, 0x05030000}, {SdoAbort::kProtocolTimedOut, 0x05040000},
      {SdoAbort::kCommandSpecifierInvalid, 0x05040001}, {SdoAbort::kInvalidBlockSize, 0x05040002},
      {SdoAbort::kInvalidSequenceNumber, 0x05040003}, {SdoAbort::kCrcError, 0x05040004},
      {SdoAbort::kOutOfMemory, 0x05040005},           {SdoAbort::kUnsupportedAccess, 0x06010000},
      {SdoAbort::kWriteOnly, 0x06010001},             {SdoAbort::kReadOnly, 0x06010002},
      {SdoAbort::kObjectDoesNotExist, 0x06020000},    {SdoAbort::kObjectCannotBeMapped, 0x06040041},
      {SdoAbort::kPdoLengthExceeded, 0x06040042},     {SdoAbort::kParameterIncompatible, 0x06040043},
      {SdoAbort::kInternalIncompatible, 0x06040047},  {SdoAbort::kHardwareError, 0x06060000},
      {SdoAbort::kLengthMismatch, 0x06070010},        {SdoAbort::kLengthTooHigh, 0x06070012},
      {SdoAbort::kLengthTooLow, 0x06070013},          {SdoAbort::kSubIndexDoesNotExist, 0x06090011},
      {SdoAbort::kInvalidValue, 0x06090030},          {SdoAbort::kValueTooHigh, 0x06090031},
      {SdoAbort::kValueTooLow, 0x06090032},           {SdoAbort::kMaxLessThanMin, 0x06090036},
      {SdoAbort::kResourceNotAvailable, 0x060A0023},  {SdoAbort::kGeneralError, 0x08000000},
      {SdoAbort::kCannotStore, 0x08000020},           {SdoAbort::kCannotStoreLocalControl, 0x08000021},
      {SdoAbort::kCannotStoreDeviceState, 0x08000022}, {SdoAbort::kNoObjectDictionary, 0x08000023},
      {SdoAbort::kNoDataAvailable, 0x08000024},
  };
  for (const Row& r : rows) {
    SCOPED_TRACE(r.wire);
    EXPECT_EQ(static_cast<uint32_t>(r.e), r.wire);
    EXPECT_TRUE(is_known_sdo_abort(r.wire));
    EXPECT_NE(sdo_abort_text(r.wire), "unknown abort code");
    const std::error_code ec = r.e;  // implicit through is_error_code_enum
    EXPECT_EQ(ec.value(), static_cast<int>(r.wire));
    EXPECT_EQ(ec.message(), std::string(sdo_abort_text(r.wire)));
  }
}

// The codes J§1.6.3 and E§7.3 list (same nine in both; F documents none),
// each with the manual's wording and the words our text must carry so a log
// reader recognises the manual's meaning.
struct ManualRow {
  uint32_t code;
  const char* manual;                 // J (translated) / E wording
  std::vector<std::string_view> must;  // words in sdo_abort_text
  std::vector<std::string_view> must_not;
};

const std::vector<ManualRow>& manual_rows() {
  static const std::vector<ManualRow> rows = {
      {0x06090011, "subindex does not exist", {"sub-index", "does not exist"}, {}},
      {0x06090030, "value exceeded", {"value", "exceeded"}, {"too high", "too low"}},
      {0x06020000, "object does not exist", {"object does not exist"}, {"sub-index"}},
      {0x06010001, "object is write only", {"read", "write only"}, {"read only"}},
      {0x06010002, "object is read only", {"write", "read only"}, {"write only"}},
      {0x06060000, "access error", {"access failed", "hardware"}, {}},
      {0x08000020, "data transport error", {"cannot be transferred or stored"}, {"local control", "device state"}},
      {0x08000000, "general error", {"general error"}, {}},
      {0x08000022, "wrong state / unfair status", {"cannot be transferred or stored", "device state"}, {"local control"}},
  };
  return rows;
}

void check_manual_rows() {
  for (const ManualRow& r : manual_rows()) {
    SCOPED_TRACE(r.manual);
    EXPECT_TRUE(is_known_sdo_abort(r.code));
    const std::string_view t = sdo_abort_text(r.code);
    for (auto w : r.must) EXPECT_TRUE(contains(t, w)) << t << " lacks " << w;
    for (auto w : r.must_not) EXPECT_FALSE(contains(t, w)) << t << " has " << w;
  }
}

// J§1.6.3 (中止コード list).
TEST(SdoAbort, J_1_6_3_ListedCodesHaveTheManualsMeaning) { check_manual_rows(); }

// E§7.3 (Abort Code list; identical codes, English wording).
TEST(SdoAbort, E_7_3_ListedCodesHaveTheManualsMeaning) {
  EXPECT_EQ(manual_rows().size(), 9u);
  check_manual_rows();
}

// CiA 301 §7.2.4.3.17: anything else a server sends is still reported, but not named.
TEST(SdoAbort, CiA301_7_2_4_3_17_UnknownCodesAreReportedAsUnknown) {
  for (uint32_t code : {0x00000000u, 0x05040006u, 0x06090033u, 0x08000025u, 0xFFFFFFFFu, 0x12345678u}) {
    SCOPED_TRACE(code);
    EXPECT_FALSE(is_known_sdo_abort(code));
    EXPECT_EQ(sdo_abort_text(code), "unknown abort code");
  }
  const std::error_code ec = sdo_abort_error(0x12345678u);
  EXPECT_EQ(ec.category(), sdo_abort_category());
  EXPECT_EQ(ec.value(), 0x12345678);
  EXPECT_EQ(ec.message(), "unknown abort code");
}

// CiA 301 §7.2.4.3.17 defines no code 0; as an error_code it would mean success.
TEST(SdoAbort, CiA301_7_2_4_3_17_WireCodeZeroBecomesGeneralError) {
  const std::error_code ec = sdo_abort_error(0);
  EXPECT_TRUE(static_cast<bool>(ec));
  EXPECT_EQ(ec, SdoAbort::kGeneralError);
}

// CiA 301 §7.2.4.3.17: error_codes compare straight against the spec values.
TEST(SdoAbort, CiA301_7_2_4_3_17_ErrorCodeCategoryAndComparison) {
  const std::error_code ec = sdo_abort_error(0x06090011);
  EXPECT_STREQ(ec.category().name(), "sdo_abort");
  EXPECT_EQ(ec, SdoAbort::kSubIndexDoesNotExist);
  EXPECT_NE(ec, SdoAbort::kObjectDoesNotExist);
  EXPECT_EQ(ec.value(), 0x06090011);
  EXPECT_EQ(ec.message(), "sub-index does not exist");
  // A value-equal code of another category is a different error.
  EXPECT_NE(ec, std::error_code(0x06090011, std::generic_category()));
}

// CiA 301 §7.2.4.3.17: what goes back on the wire for a given error.
TEST(SdoAbort, CiA301_7_2_4_3_17_WireCodeOfAnErrorCode) {
  EXPECT_EQ(sdo_abort_wire_code(SdoAbort::kReadOnly), 0x06010002u);
  EXPECT_EQ(sdo_abort_wire_code(sdo_abort_error(0x0BADC0DE)), 0x0BADC0DEu);
  EXPECT_EQ(sdo_abort_wire_code(std::make_error_code(std::errc::io_error)), 0x08000000u);
  EXPECT_EQ(sdo_abort_wire_code(std::error_code{}), 0x08000000u);
}

}  // namespace
}  // namespace cobridge::canopen
