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
  const Result<std::string> back = unescape_field(escaped);
  ASSERT_TRUE(back.ok()) << back.error().to_string();
  EXPECT_EQ(*back, all);
}

TEST(FieldText, PlainTextIsLeftAsItIs) {
  EXPECT_EQ(escape_field("lift-1_A.b"), "lift-1_A.b");
  EXPECT_EQ(escape_field("a b=c%d#"), "a%20b%3Dc%25d%23");
}

TEST(FieldText, SplitsKeyValueFieldsInOrder) {
  const Result<Fields> f = split_fields("  at=12\tkind=state  text=a%20b ");
  ASSERT_TRUE(f.ok()) << f.error().to_string();
  ASSERT_EQ(f->size(), 3U);
  EXPECT_EQ((*f)[0], (std::pair<std::string, std::string>{"at", "12"}));
  EXPECT_EQ((*f)[2], (std::pair<std::string, std::string>{"text", "a b"}));
  const Result<Fields> none = split_fields("");
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty());
}

TEST(FieldText, ABadTokenIsNamed) {
  const auto why = [](std::string_view line) {
    const Result<Fields> f = split_fields(line);
    EXPECT_FALSE(f.ok()) << line;
    EXPECT_EQ(f.error().kind, Errc::kInvalidArgument) << line;
    return f.error().message;
  };
  EXPECT_EQ(why("at=1 oops"), "expected key=value, got 'oops'");
  EXPECT_EQ(why("=1"), "expected key=value, got '=1'");
  EXPECT_EQ(why("text=50%"), "bad %-escape in 'text=50%'");
  EXPECT_EQ(why("text=%4"), "bad %-escape in 'text=%4'");
  EXPECT_EQ(why("text=%zz"), "bad %-escape in 'text=%zz'");
  EXPECT_FALSE(unescape_field("%G0").ok());
}

}  // namespace
}  // namespace cobridge
