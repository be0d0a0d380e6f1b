// Issue 10, item 13: a configuration nested 50 000 levels deep overflowed the
// stack of the TOML parser (--check-config crashed, SIGHUP killed the daemon).
// Size and nesting are checked before parsing, with file:line:col.
#include "config/toml_limits.hpp"

#include <gtest/gtest.h>

#include <string>

#include "config/load.hpp"

namespace cobridge::config {
namespace {

std::string nested(std::size_t depth, char open, char close, std::string_view inner) {
  return "a = " + std::string(depth, open) + std::string(inner) + std::string(depth, close) + "\n";
}

TEST(TomlLimits, FiftyThousandLevelsAreAnErrorNotACrash) {
  for (const auto& text : {nested(50000, '[', ']', "1"), "x = 1\n" + std::string(50000, '{')}) {
    const LoadResult r = load_string(text, "deep.toml");
    ASSERT_FALSE(r.ok());
    const std::string e = to_string(r.diagnostics().front());
    EXPECT_NE(e.find("nested more than 32 levels"), std::string::npos) << e;
    EXPECT_NE(e.find("deep.toml:"), std::string::npos) << e;
  }
}

TEST(TomlLimits, DepthLimitNamesTheFirstBracketTooDeep) {
  const auto v = check_toml_limits("x = 1\ny = [[[[1]]]]\n", 1 << 20, 3);
  ASSERT_TRUE(v.has_value());
  EXPECT_EQ(v->line, 2u);
  EXPECT_EQ(v->column, 8u);
  EXPECT_FALSE(check_toml_limits("y = [[[1]]]\n", 1 << 20, 3).has_value());
}

// Brackets inside strings and comments do not nest anything (TOML 1.0 strings).
TEST(TomlLimits, StringsAndCommentsAreNotCounted) {
  const std::string text = "a = \"[[[[[[\"\nb = '{{{{{{'\nc = \"\"\"\n[[[[[[\n\"\"\"\nd = '''{{{{{{'''\n"
                           "e = \"\\\"[[[[[[\"\n# [[[[[[[[\n[[bus]]\n";
  EXPECT_FALSE(check_toml_limits(text, 1 << 20, 2).has_value());
}

TEST(TomlLimits, SizeLimit) {
  const std::string big(kMaxConfigBytes + 1, '#');
  const auto v = check_toml_limits(big);
  ASSERT_TRUE(v.has_value());
  EXPECT_NE(v->message.find("at most 1048576"), std::string::npos);
  EXPECT_FALSE(load_string(big, "big.toml").ok());
}

}  // namespace
}  // namespace cobridge::config
