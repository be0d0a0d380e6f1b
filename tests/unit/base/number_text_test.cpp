// base/number_text: the one parser of numbers and octet strings typed into
// the control socket, the CiA 309-3 gateway (CiA 309-3 §5: numbers decimal or
// 0x-hex; octet strings as hex pairs) and the state file.
#include "base/number_text.hpp"

#include <gtest/gtest.h>

namespace {

using cobridge::parse_hex_bytes;
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

}  // namespace
