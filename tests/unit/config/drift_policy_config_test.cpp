// [[device]] on_config_drift (docs/configuration.md "[[device]]"):
// "restore" by default, "keep" taken, anything else an error at
// the value's line naming the key and the allowed values.
#include "config/load.hpp"
#include "unit/config/one_bus_config.hpp"

#include <gtest/gtest.h>

#include <string>

using cobridge::config::DriftPolicy;
using cobridge::config::load_string;

namespace {

const std::string kDevice = cobridge::config::test::kOneBus +
                            "[[device]]\nname = \"enc\"\nbus = \"line1\"\nserial = 1001\nmodel = \"RFC-4800\"\n";

std::string all(const cobridge::config::LoadResult& r) { return cobridge::config::test::all_diagnostics(r); }

TEST(DriftPolicyConfig, RestoreIsTheDefault) {
  const auto r = load_string(kDevice, "t.toml", "/tmp");
  ASSERT_TRUE(r.ok()) << all(r);
  EXPECT_EQ(r.config().devices.at(0).on_config_drift, DriftPolicy::restore);
}

TEST(DriftPolicyConfig, KeepAndRestoreAreTaken) {
  auto r = load_string(kDevice + "on_config_drift = \"keep\"\n", "t.toml", "/tmp");
  ASSERT_TRUE(r.ok()) << all(r);
  EXPECT_EQ(r.config().devices.at(0).on_config_drift, DriftPolicy::keep);
  r = load_string(kDevice + "on_config_drift = \"restore\"\n", "t.toml", "/tmp");
  ASSERT_TRUE(r.ok()) << all(r);
  EXPECT_EQ(r.config().devices.at(0).on_config_drift, DriftPolicy::restore);
}

TEST(DriftPolicyConfig, AnotherValueIsAnErrorAtItsLineWithTheAllowedValues) {
  const auto r = load_string(kDevice + "on_config_drift = \"ignore\"\n", "t.toml", "/tmp");
  ASSERT_FALSE(r.ok());
  const auto& d = r.diagnostics();
  ASSERT_EQ(d.size(), 1u) << all(r);
  EXPECT_EQ(d[0].line, 14u) << all(r);
  for (const char* word : {"on_config_drift", "ignore", "restore", "keep"})
    EXPECT_NE(d[0].message.find(word), std::string::npos) << word << " in " << d[0].message;
  const auto wrong_type = load_string(kDevice + "on_config_drift = true\n", "t.toml", "/tmp");
  EXPECT_FALSE(wrong_type.ok());
}

}  // namespace
