// A configuration nested 50 000 levels deep, or 100 000 levels of dotted
// keys and table headers, would overflow the stack of the TOML parser (a
// crash of --check-config, or of the daemon on SIGHUP). Size and nesting are
// checked before parsing, with file:line:col; every form of nesting counts
// (levels: toml_limits.hpp).
#include "config/toml_limits.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "config/load.hpp"

namespace cobridge::config {
namespace {

std::string nested(std::size_t depth, char open, char close, std::string_view inner) {
  return "a = " + std::string(depth, open) + std::string(inner) + std::string(depth, close) + "\n";
}

// `segments` segments joined by dots: "a.a.a".
std::string dotted(std::size_t segments) {
  std::string s = "a";
  for (std::size_t i = 1; i < segments; ++i) s += ".a";
  return s;
}

// The first diagnostic of `text` loaded as deep.toml, as --check-config prints it.
std::string first_error(const std::string& text) {
  const LoadResult r = load_string(text, "deep.toml");
  return r.ok() ? "(accepted)" : to_string(r.diagnostics().front());
}

// "line:column" of the first level too deep, or "within".
std::string with_limit(std::size_t max_depth, const std::string& text) {
  const auto v = check_toml_limits(text, 1 << 20, max_depth);
  return v ? std::to_string(v->line) + ":" + std::to_string(v->column) : "within";
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

// Each form after a comment line of deep.toml, 100 000 levels deep: toml++ recursed once
// per dotted segment too (--check-config died of SIGSEGV).
TEST(TomlLimits, HundredThousandLevelsOfKeysOrHeadersAreAnErrorNotACrash) {
  const std::string deep = dotted(100000);
  for (const std::string& form : {deep + " = 1", "[" + deep + "]", "[[" + deep + "]]", "x = { " + deep + " = 1 }",
                                  "[gateway]\n" + deep + " = 1"}) {
    const std::string e = first_error("# deep\n" + form + "\n");
    EXPECT_NE(e.find("nested more than 32 levels deep"), std::string::npos) << form.substr(0, 20) << ": " << e;
    EXPECT_EQ(e.rfind("deep.toml:", 0), 0u) << e;
  }
}

// At the limit (32 levels) accepted; one level more refused at line:column of
// the dot that starts the segment too deep.
TEST(TomlLimits, DottedKeyOf32SegmentsAcceptedOf33RefusedAtItsDot) {
  EXPECT_EQ(with_limit(32, "x = 1\n" + dotted(32) + " = 1\n"), "within");
  EXPECT_EQ(with_limit(32, "x = 1\n" + dotted(33) + " = 1\n"), "2:64");  // the 32nd dot
  EXPECT_EQ(first_error("x = 1\n" + dotted(33) + " = 1\n").substr(0, 52),
            "deep.toml:2:64: key nested more than 32 levels deep ");
}

TEST(TomlLimits, TableHeaderOf32SegmentsAcceptedOf33Refused) {
  EXPECT_EQ(with_limit(32, "x = 1\n[" + dotted(32) + "]\n"), "within");
  EXPECT_EQ(with_limit(32, "x = 1\n[" + dotted(33) + "]\n"), "2:65");
  EXPECT_EQ(first_error("x = 1\n[" + dotted(33) + "]\n").substr(0, 61),
            "deep.toml:2:65: table header nested more than 32 levels deep ");
}

// [[a]]: the array a, and its element one level below.
TEST(TomlLimits, ArrayOfTablesHeaderCountsItsElement) {
  EXPECT_EQ(with_limit(32, "x = 1\n[[" + dotted(31) + "]]\n"), "within");
  EXPECT_EQ(with_limit(32, "x = 1\n[[" + dotted(32) + "]]\n"), "2:64");  // the 31st dot
  EXPECT_EQ(first_error("x = 1\n[[" + dotted(32) + "]]\n").substr(0, 61),
            "deep.toml:2:64: table header nested more than 32 levels deep ");
  EXPECT_EQ(with_limit(1, "[[bus]]\n"), "1:1");
}

// y = { ... }: the inline table is y's value (level 1), its keys below it.
TEST(TomlLimits, DottedKeyInAnInlineTableCountsTheTable) {
  EXPECT_EQ(with_limit(32, "x = 1\ny = { " + dotted(31) + " = 1 }\n"), "within");
  EXPECT_EQ(with_limit(32, "x = 1\ny = { " + dotted(32) + " = 1 }\n"), "2:68");  // the 31st dot
  EXPECT_EQ(with_limit(32, "y = { b = 2, " + dotted(32) + " = 1 }\n"), "1:75");   // the key after a comma
  EXPECT_EQ(first_error("x = 1\ny = { " + dotted(32) + " = 1 }\n").substr(0, 52),
            "deep.toml:2:68: key nested more than 32 levels deep ");
}

// The levels of the header, the keys below it, arrays and inline tables add up.
TEST(TomlLimits, HeaderKeysArraysAndInlineTablesAddUp) {
  EXPECT_EQ(with_limit(32, "[a.b]\n" + dotted(30) + " = 1\n"), "within");
  EXPECT_EQ(with_limit(32, "[a.b]\n" + dotted(31) + " = 1\n"), "2:60");
  EXPECT_EQ(with_limit(32, "[[a]]\n" + dotted(31) + " = 1\n"), "2:60");
  // [a] 1, k 2, its array 2, the inline table in it 3, b 4, b's array 4.
  EXPECT_EQ(with_limit(4, "[a]\nk = [{ b = [1] }]\n"), "within");
  EXPECT_EQ(with_limit(3, "[a]\nk = [{ b = [1] }]\n"), "2:8");
  // A key right below a header at the limit is one level too deep.
  EXPECT_EQ(with_limit(2, "[a.b]\nc = 1\n"), "2:1");
  // The next header starts from the top again.
  EXPECT_EQ(with_limit(3, "[a.b.c]\n[d]\ne.f = 1\n"), "within");
}

// A quoted segment is one level, dots and all; dots in values separate nothing.
TEST(TomlLimits, QuotedSegmentsAndValuesHaveNoSeparators) {
  EXPECT_EQ(with_limit(1, "\"a.b.c.d\" = 1\n['x.y.z']\n"), "within");
  EXPECT_EQ(with_limit(2, "q = { \"r.s\" = 1 }\n\"a.b\".'c.d' = 1\n[\"x.y\".z]\n"), "within");
  EXPECT_EQ(with_limit(1, "\"a.b\".c = 1\n"), "1:6");
  EXPECT_EQ(with_limit(2, "a = 1.5\nb = 1979-05-27T07:32:00.999\nc = [1.5, 2.5]\nd = { e = 0.25, f = 1e1 }\n"),
            "within");
  EXPECT_EQ(with_limit(2, "d = { e = 0.25, f.g = 1 }\n"), "1:18");
}

// A comment or a one-line string ends at the line's end, and the next line's
// key is counted from its table again (the line end is not lost inside them).
TEST(TomlLimits, KeysAfterACommentOrStringAreCounted) {
  EXPECT_EQ(with_limit(2, "a = 1 # note\nb.b.b = 1\n"), "2:4");
  EXPECT_EQ(with_limit(2, "a = 'x'\nb.b.b = 1\n"), "2:4");
  EXPECT_EQ(with_limit(2, "a = \"\"\"\nx.x.x\n\"\"\"\nb.b = 1\n"), "within");
  // A multi-line string may end in five quotes: the last two open no string.
  EXPECT_EQ(with_limit(3, "a = [\"\"\"x\"\"\"\"\", [[[1]]]]\n"), "1:19");
  EXPECT_EQ(with_limit(3, "a = ['''x''''', [[[1]]]]\n"), "1:19");
}

// The configurations in the tree are far from the limit (the deepest is 4:
// a key of [[device.cam]]).
TEST(TomlLimits, ShippedConfigurationsAreWithinTheLimit) {
  namespace fs = std::filesystem;
  const fs::path root = fs::path(__FILE__).parent_path().parent_path().parent_path().parent_path();
  std::size_t files = 0;
  for (const fs::path& dir : {root / "config", root / "tests" / "unit" / "config" / "fixtures"}) {
    for (const auto& entry : fs::directory_iterator(dir)) {
      if (entry.path().extension() != ".toml") continue;
      std::ostringstream text;
      text << std::ifstream(entry.path()).rdbuf();
      EXPECT_EQ(with_limit(4, text.str()), "within") << entry.path();
      ++files;
    }
  }
  EXPECT_GE(files, 10u);
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
