// The flight recorder's [[bus]] keys (docs/configuration.md "[[bus]]":
// recorder_seconds, capture_after_s, capture_cap_mib): defaults, every key,
// out-of-range values at their line.
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
  EXPECT_EQ(b.capture_after_s, 2u);
  EXPECT_EQ(b.capture_cap_mib, 64u);
}

TEST(RecorderConfig, EveryKeyAndZeroTurnsTheRecorderOff) {
  const auto r = load_string(kBase + "recorder_seconds = 0\ncapture_after_s = 5\ncapture_cap_mib = 8\n", "t.toml", "/tmp");
  ASSERT_TRUE(r.ok()) << all(r);
  const auto& b = r.config().buses.at(0);
  EXPECT_EQ(b.recorder_seconds, 0u);
  EXPECT_EQ(b.capture_after_s, 5u);
  EXPECT_EQ(b.capture_cap_mib, 8u);
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

}  // namespace
