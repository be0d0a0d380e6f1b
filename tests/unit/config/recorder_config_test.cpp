// The flight recorder's [[bus]] keys (docs/configuration.md "[[bus]]":
// recorder_seconds, capture_after_s, capture_cap_mib,
// capture_budget_per_hour): defaults, every key, out-of-range values at
// their line.
#include "config/load.hpp"
#include "unit/config/one_bus_config.hpp"

#include <gtest/gtest.h>

#include <string>

using cobridge::config::load_string;

namespace {

const std::string& kBase = cobridge::config::test::kOneBus;

std::string all(const cobridge::config::LoadResult& r) { return cobridge::config::test::all_diagnostics(r); }

TEST(RecorderConfig, DefaultsAreTheDocumentedOnes) {
  const auto r = load_string(kBase, "t.toml", "/tmp");
  ASSERT_TRUE(r.ok()) << all(r);
  const auto& b = r.config().buses.at(0);
  EXPECT_EQ(b.recorder_seconds, 10u);
  EXPECT_EQ(b.capture_after_ms, 2000u);
  EXPECT_EQ(b.capture_cap_mib, 64u);
  EXPECT_EQ(b.capture_budget_per_hour, 60u);
}

TEST(RecorderConfig, EveryKeyAndZeroTurnsTheRecorderOff) {
  const auto r = load_string(
      kBase + "recorder_seconds = 0\ncapture_after_s = 5\ncapture_cap_mib = 8\ncapture_budget_per_hour = 12\n",
      "t.toml", "/tmp");
  ASSERT_TRUE(r.ok()) << all(r);
  const auto& b = r.config().buses.at(0);
  EXPECT_EQ(b.recorder_seconds, 0u);
  EXPECT_EQ(b.capture_after_ms, 5000u);
  EXPECT_EQ(b.capture_cap_mib, 8u);
  EXPECT_EQ(b.capture_budget_per_hour, 12u);
}

TEST(RecorderConfig, OutOfRangeValuesAreErrorsAtTheirLine) {
  const auto r = load_string(kBase + "recorder_seconds = 601\ncapture_after_s = -1\ncapture_cap_mib = 0\n", "t.toml", "/tmp");
  ASSERT_FALSE(r.ok());
  const auto& d = r.diagnostics();
  ASSERT_EQ(d.size(), 3u) << all(r);
  EXPECT_EQ(d[0].line, 9u);
  EXPECT_NE(d[0].message.find("recorder_seconds"), std::string::npos) << d[0].message;
  EXPECT_NE(d[0].message.find("0..600"), std::string::npos) << d[0].message;
  EXPECT_EQ(d[1].line, 10u);
  EXPECT_NE(d[1].message.find("capture_after_s"), std::string::npos) << d[1].message;
  EXPECT_EQ(d[2].line, 11u);
  EXPECT_NE(d[2].message.find("capture_cap_mib"), std::string::npos) << d[2].message;
}

// `capture_after_s` takes a fraction of a second, and at
// least 0.5 s: at 0 a storm of faults wrote up to 16 captures per 100 ms
// (the cap bounds the space, not the flash's wear). A smaller value is an
// error naming the key, the file and the line.
TEST(RecorderConfig, CaptureAfterIsAtLeastHalfASecond) {
  const auto half = load_string(kBase + "capture_after_s = 0.5\n", "t.toml", "/tmp");
  ASSERT_TRUE(half.ok()) << all(half);
  EXPECT_EQ(half.config().buses.at(0).capture_after_ms, 500u);
  for (const char* bad : {"0", "0.4", "0.0", "nan", "61"}) {
    const auto r = load_string(kBase + "capture_after_s = " + bad + "\n", "site.toml", "/tmp");
    ASSERT_FALSE(r.ok()) << bad;
    const auto& d = r.diagnostics();
    ASSERT_EQ(d.size(), 1u) << all(r);
    EXPECT_EQ(d[0].file, "site.toml");
    EXPECT_EQ(d[0].line, 9u);
    EXPECT_NE(d[0].message.find("capture_after_s"), std::string::npos) << d[0].message;
    EXPECT_NE(d[0].message.find("allowed: 0.5..60"), std::string::npos) << d[0].message;
  }
  const auto text = load_string(kBase + "capture_after_s = \"2\"\n", "t.toml", "/tmp");
  ASSERT_FALSE(text.ok());
  EXPECT_NE(all(text).find("capture_after_s"), std::string::npos) << all(text);
}

// The captures' write budget per hour, 1..7200.
TEST(RecorderConfig, TheCaptureBudgetIsBounded) {
  for (const char* bad : {"0", "7201", "-1"}) {
    const auto r = load_string(kBase + "capture_budget_per_hour = " + bad + "\n", "t.toml", "/tmp");
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(all(r).find(std::string("capture_budget_per_hour ") + bad + " is out of range (allowed: 1..7200)"), std::string::npos)
        << all(r);
  }
}

}  // namespace
