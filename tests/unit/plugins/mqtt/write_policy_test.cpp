// The Sparkplug output's write policy: the Modbus output's shape
// (writes_enabled, write_allow), matched on device and command.
#include "write_policy.hpp"

#include <cobridge/plugin.h>

#include <gtest/gtest.h>

namespace cobridge::mqtt {
namespace {

TEST(WritePolicy, DisabledRefusesEverything) {
  const WritePolicy p;
  EXPECT_NE(p.refusal("rot", COBRIDGE_COMMAND_PRESET).find("writes are disabled"), std::string::npos);
}

TEST(WritePolicy, EmptyAllowListTakesEverything) {
  WritePolicy p;
  p.enabled = true;
  EXPECT_EQ(p.refusal("rot", COBRIDGE_COMMAND_STORE), "");
}

TEST(WritePolicy, AllowListByDeviceAndCommand) {
  WritePolicy p;
  p.enabled = true;
  for (const char* e : {"rot", "mt:preset", "*:store"}) {
    WriteRule r;
    ASSERT_EQ(parse_write_rule(e, r), "") << e;
    p.allow.push_back(r);
  }
  EXPECT_EQ(p.refusal("rot", COBRIDGE_COMMAND_NMT_RESET), "");
  EXPECT_EQ(p.refusal("mt", COBRIDGE_COMMAND_PRESET), "");
  EXPECT_EQ(p.refusal("ifm", COBRIDGE_COMMAND_STORE), "");
  EXPECT_NE(p.refusal("mt", COBRIDGE_COMMAND_NMT_RESET).find("nmt_reset on device mt is not in"), std::string::npos);
  EXPECT_NE(p.refusal("ifm", COBRIDGE_COMMAND_PRESET), "");
}

TEST(WritePolicy, BadRules) {
  WriteRule r;
  EXPECT_NE(parse_write_rule("rot:reboot", r).find("'reboot'"), std::string::npos);
  EXPECT_NE(parse_write_rule(":store", r), "");
  EXPECT_NE(parse_write_rule("*", r), "");
}

}  // namespace
}  // namespace cobridge::mqtt
