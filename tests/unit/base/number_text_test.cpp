// base/number_text: the one parser of numbers and octet strings typed into
// the control socket, the CiA 309-3 gateway (CiA 309-3 §5: numbers decimal or
// 0x-hex; octet strings as hex pairs) and the state file.
#include "base/number_text.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace {

using cobridge::parse_hex_bytes;
using cobridge::parse_signed;
using cobridge::hex;
using cobridge::hex_bytes;
using cobridge::object_text;
using cobridge::parse_unsigned;

TEST(NumberText, DecimalAndPrefixedHexUpToTheLimit) {
  std::uint64_t v = 0;
  EXPECT_TRUE(parse_unsigned("127", 127, v));
  EXPECT_EQ(v, 127U);
  EXPECT_TRUE(parse_unsigned("0x1018", 0xFFFF, v));
  EXPECT_EQ(v, 0x1018U);
  EXPECT_TRUE(parse_unsigned("0XfF", 0xFF, v));
  EXPECT_EQ(v, 0xFFU);
  EXPECT_TRUE(parse_unsigned("6000", 0xFFFF, v, true));  // an index is hex without 0x
  EXPECT_EQ(v, 0x6000U);
}

TEST(NumberText, AnythingElseIsRefusedAndLeavesTheOutputAlone) {
  std::uint64_t v = 42;
  for (const char* bad : {"", "0x", "128", "-1", "+1", "12a", " 1", "1 ", "0x1g", "99999999999999999999999"})
    EXPECT_FALSE(parse_unsigned(bad, 127, v)) << bad;
  EXPECT_EQ(v, 42U);
  EXPECT_FALSE(parse_unsigned("0x10000", 0xFFFF, v));
}

// A signed number's hex digits are its magnitude, range-checked
// like its decimal form (0x12345 for a 16-bit value was truncated to 0x2345).
TEST(NumberText, SignedDecimalAndHexWithinTheRange) {
  std::int64_t v = 0;
  EXPECT_TRUE(parse_signed("-32768", -32768, 32767, v));
  EXPECT_EQ(v, -32768);
  EXPECT_TRUE(parse_signed("0x7FFF", -32768, 32767, v));
  EXPECT_EQ(v, 32767);
  EXPECT_TRUE(parse_signed("-0x8000", -32768, 32767, v));
  EXPECT_EQ(v, -32768);
  EXPECT_TRUE(parse_signed("-0", -1, 1, v));
  EXPECT_EQ(v, 0);
  EXPECT_TRUE(parse_signed("010", -100, 100, v));  // no octal
  EXPECT_EQ(v, 10);
  EXPECT_TRUE(parse_signed("-9223372036854775808", INT64_MIN, INT64_MAX, v));
  EXPECT_EQ(v, INT64_MIN);
  EXPECT_TRUE(parse_signed("-0x8000000000000000", INT64_MIN, INT64_MAX, v));
  EXPECT_EQ(v, INT64_MIN);
  EXPECT_TRUE(parse_signed("0x7FFFFFFFFFFFFFFF", INT64_MIN, INT64_MAX, v));
  EXPECT_EQ(v, INT64_MAX);
}

TEST(NumberText, SignedOutOfRangeOrMalformedIsRefusedAndLeavesTheOutputAlone) {
  std::int64_t v = 42;
  for (const char* bad : {"", "-", "--1", "+1", "-+1", "- 1", "32768", "-32769", "0x8000", "0xFFFF", "0x12345",
                          "-0x8001", "0x", "-0x", "1a", "0x1g", "99999999999999999999999"})
    EXPECT_FALSE(parse_signed(bad, -32768, 32767, v)) << bad;
  for (const char* bad : {"9223372036854775808", "-9223372036854775809", "0x8000000000000000",
                          "0xFFFFFFFFFFFFFFFF", "-0x8000000000000001", "0x10000000000000000"})
    EXPECT_FALSE(parse_signed(bad, INT64_MIN, INT64_MAX, v)) << bad;
  EXPECT_EQ(v, 42);
}

TEST(NumberText, HexBytesArePairsWithinTheLimit) {
  std::vector<std::uint8_t> out;
  EXPECT_TRUE(parse_hex_bytes("0A1bFF", 3, out));
  EXPECT_EQ(out, (std::vector<std::uint8_t>{0x0A, 0x1B, 0xFF}));
  for (const char* bad : {"", "A", "0A1", "0G", "0A 1"}) {
    out.clear();
    EXPECT_FALSE(parse_hex_bytes(bad, 8, out)) << bad;
  }
  out.clear();
  EXPECT_FALSE(parse_hex_bytes("00112233", 3, out));  // 4 bytes > 3
}

// The printer beside the parser: what the daemon writes, the parser reads.
TEST(NumberText, HexPadsToTheDigitsAskedAndReadsBack) {
  EXPECT_EQ(hex(0x1A), "0x1A");
  EXPECT_EQ(hex(0x1A, 4), "0x001A");
  EXPECT_EQ(hex(0, 0), "0x0");
  EXPECT_EQ(hex(0xFFFFFFFFu, 8), "0xFFFFFFFF");
  EXPECT_EQ(hex(0x123456789ULL, 8), "0x123456789");  // never cut to the width
  std::uint64_t back = 0;
  ASSERT_TRUE(parse_unsigned(hex(0xBEEF, 8), 0xFFFFFFFFu, back));
  EXPECT_EQ(back, 0xBEEFu);
}

TEST(NumberText, HexBytesArePairsParseHexBytesReads) {
  const std::vector<std::uint8_t> bytes{0x0A, 0x1B, 0x00, 0xFF};
  EXPECT_EQ(hex_bytes(bytes), "0A1B00FF");
  EXPECT_EQ(hex_bytes({}), "");
  std::vector<std::uint8_t> back;
  ASSERT_TRUE(parse_hex_bytes(hex_bytes(bytes), 8, back));
  EXPECT_EQ(back, bytes);
}

// CiA 301 §7.4.1: an object is an index and a sub-index.
TEST(NumberText, Cia301_7_4_1_ObjectTextNamesSubIndexOnlyWhenNotZero) {
  EXPECT_EQ(object_text(0x1017, 0), "0x1017");
  EXPECT_EQ(object_text(0x1A00, 2), "0x1A00/2");
  EXPECT_EQ(object_text(0x6000, 255), "0x6000/255");
}

}  // namespace
