// Field text: the line format of the gateway's state file and timeline
// journal; any text survives a round trip on one line.
#include "base/field_text.hpp"

#include <gtest/gtest.h>

namespace cobridge {
namespace {

TEST(FieldText, EveryByteSurvivesTheRoundTrip) {
  std::string all;
  for (int c = 1; c < 256; ++c) all += static_cast<char>(c);
  const std::string escaped = escape_field(all);
  EXPECT_EQ(escaped.find_first_of(" \t\n\r=#"), std::string::npos);
  std::string back;
  ASSERT_TRUE(unescape_field(escaped, back));
  EXPECT_EQ(back, all);
}

TEST(FieldText, PlainTextIsLeftAsItIs) {
  EXPECT_EQ(escape_field("lift-1_A.b"), "lift-1_A.b");
  EXPECT_EQ(escape_field("a b=c%d#"), "a%20b%3Dc%25d%23");
}

TEST(FieldText, SplitsKeyValueFieldsInOrder) {
  Fields f;
  std::string why;
  ASSERT_TRUE(split_fields("  at=12\tkind=state  text=a%20b ", f, why)) << why;
  ASSERT_EQ(f.size(), 3U);
  EXPECT_EQ(f[0], (std::pair<std::string, std::string>{"at", "12"}));
  EXPECT_EQ(f[2], (std::pair<std::string, std::string>{"text", "a b"}));
  EXPECT_TRUE(split_fields("", f, why));
  EXPECT_TRUE(f.empty());
}

TEST(FieldText, ABadTokenIsNamed) {
  Fields f;
  std::string why;
  EXPECT_FALSE(split_fields("at=1 oops", f, why));
  EXPECT_EQ(why, "expected key=value, got 'oops'");
  EXPECT_FALSE(split_fields("=1", f, why));
  EXPECT_FALSE(split_fields("text=50%", f, why));
  EXPECT_EQ(why, "bad %-escape in 'text=50%'");
  EXPECT_FALSE(split_fields("text=%4", f, why));
  EXPECT_FALSE(split_fields("text=%zz", f, why));
}

}  // namespace
}  // namespace cobridge
