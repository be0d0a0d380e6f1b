// cobridge-sim --device MODEL[:key=value,...] parsing. The model table is a
// test table, so these tests do not depend on the device runtime.
#include "app/device_argument.hpp"

#include <gtest/gtest.h>

#include <array>

namespace cobridge::sim {
namespace {

constexpr std::array<ModelInfo, 3> kTestModels{{
    {"RFC-4800", FamilyId::novotechnik_rotary, 0x182, 0x0BE0, 127, false, "novotechnik-rfc4800", 250},
    {"MC1-2800", FamilyId::novotechnik_multiturn, 0x182, 0x0BB8, 127, false, "novotechnik-multiturn", 250},
    {"RM9000", FamilyId::ifm_rm, 0x0069666D, 0x4341, 32, false, "ifm-rm8-rm9", 125},
}};

const ModelInfo* lookup(std::string_view name) noexcept {
  for (const ModelInfo& m : kTestModels)
    if (m.name == name) return &m;
  return nullptr;
}

DeviceSpec ok(std::string_view text) {
  const auto r = parse_device_argument(text, &lookup);
  EXPECT_TRUE(r.ok()) << r.error().to_string();
  return r.ok() ? r.value().spec : DeviceSpec{};
}

std::string error(std::string_view text) {
  const auto r = parse_device_argument(text, &lookup);
  EXPECT_FALSE(r.ok()) << text;
  return r.error().to_string();
}

TEST(DeviceArgument, ModelAloneGivesFactoryDefaults) {
  const DeviceSpec s = ok("RFC-4800");
  EXPECT_EQ(s.model, &kTestModels[0]);
  EXPECT_EQ(s.node_id, 0);  // 0 = the model's factory node-ID (J§1.2.2: 127)
  EXPECT_EQ(s.channels, 1);
  EXPECT_EQ(s.lss, LssProfile::family_default);
  EXPECT_TRUE(s.segmented_sdo);
  EXPECT_EQ(s.motion, "constant:0");
}

TEST(DeviceArgument, AllKeys) {
  const DeviceSpec s = ok("RFC-4800:serial=0x12345678,node=5,channels=2,bitrate=500,lss=v3,segmented=off");
  EXPECT_EQ(s.serial, 0x12345678u);
  EXPECT_EQ(s.node_id, 5);
  EXPECT_EQ(s.channels, 2);
  EXPECT_EQ(s.bitrate_kbit, 500);
  EXPECT_EQ(s.lss, LssProfile::v3);
  EXPECT_FALSE(s.segmented_sdo);
}

// Another vendor's device that refuses LSS node-ID assignment:
// identity fields override the model's, `assign` sets the LSS behaviour.
TEST(DeviceArgument, ForeignIdentityAndAssignment) {
  const DeviceSpec s = ok("MC1-2800:serial=9,node=unconfigured,vendor=0x4711,product=0x22,revision=3,assign=refuse");
  EXPECT_EQ(s.vendor, 0x4711u);
  EXPECT_EQ(s.product, 0x22u);
  EXPECT_EQ(s.revision, 3u);
  EXPECT_EQ(s.assign, canopen::LssSlaveFeatures::NodeIdAssignment::refuse);
  EXPECT_EQ(ok("MC1-2800:assign=ignore").assign, canopen::LssSlaveFeatures::NodeIdAssignment::ignore);
  EXPECT_NE(error("MC1-2800:assign=maybe").find("assign must be accept|refuse|ignore"), std::string::npos);
  // A lossy slave: the first N configure node-ID requests are lost.
  EXPECT_EQ(ok("MC1-2800:node=unconfigured,lose_configure=2").lose_configure, 2);
  EXPECT_NE(error("MC1-2800:lose_configure=300").find("lose_configure must be 0..255"), std::string::npos);
  // Late LSS answers: every Nth, T ms late; the two keys go together.
  const DeviceSpec late = ok("MC1-2800:node=unconfigured,late_lss=3,late_lss_ms=150");
  EXPECT_EQ(late.late_lss, 3);
  EXPECT_EQ(late.late_lss_ms, 150);
  EXPECT_NE(error("MC1-2800:late_lss=3").find("late_lss and late_lss_ms go together"), std::string::npos);
  EXPECT_NE(error("MC1-2800:late_lss_ms=5").find("late_lss and late_lss_ms go together"), std::string::npos);
  EXPECT_NE(error("MC1-2800:late_lss=256,late_lss_ms=5").find("late_lss must be 0..255"), std::string::npos);
  EXPECT_NE(error("MC1-2800:late_lss=1,late_lss_ms=60001").find("late_lss_ms must be 0..60000"), std::string::npos);
  EXPECT_NE(error("MC1-2800:vendor=x").find("vendor must be a 32-bit number"), std::string::npos);
}

// CiA 305: node-ID FFh is "unconfigured" (LSS only).
TEST(DeviceArgument, UnconfiguredNode) { EXPECT_EQ(ok("MC1-2800:node=unconfigured").node_id, 0xFF); }

// The motion grammar uses ':' and ','; motion takes the rest of the argument.
TEST(DeviceArgument, MotionTakesTheRest) {
  EXPECT_EQ(ok("MC1-2800:serial=7,motion=sine:0.5:2:1").motion, "sine:0.5:2:1");
  EXPECT_EQ(ok("MC1-2800:motion=steps:0=0;1.5=2").motion, "steps:0=0;1.5=2");
}

// J§1.3.3 node-ID range 1..127.
TEST(DeviceArgument, NodeOutOfRangeIsNamed) {
  const std::string e = error("RFC-4800:node=128");
  EXPECT_NE(e.find("node must be 1..127"), std::string::npos) << e;
  EXPECT_NE(error("RFC-4800:node=0").find("node"), std::string::npos);
}

// J§1.2.2 ordering-code bit rates vs F§7.4 0x3001 table (20 kbit/s only ifm).
TEST(DeviceArgument, BitRatePerFamily) {
  EXPECT_EQ(ok("RM9000:bitrate=20").bitrate_kbit, 20);
  const std::string e = error("RFC-4800:bitrate=20");
  EXPECT_NE(e.find("50|125|250|500|800|1000"), std::string::npos) << e;
}

TEST(DeviceArgument, ChannelsOnlyForRotary) {
  EXPECT_NE(error("MC1-2800:channels=2").find("rotary"), std::string::npos);
  EXPECT_NE(error("RFC-4800:channels=3").find("1 or 2"), std::string::npos);
}

TEST(DeviceArgument, BadInputsAreErrorsNotCrashes) {
  EXPECT_NE(error("NOPE").find("unknown model 'NOPE'"), std::string::npos);
  EXPECT_NE(error("RFC-4800:").find("nothing after"), std::string::npos);
  EXPECT_NE(error("RFC-4800:serial").find("key=value"), std::string::npos);
  EXPECT_NE(error("RFC-4800:serial=").find("no value"), std::string::npos);
  EXPECT_NE(error("RFC-4800:serial=1,").find("trailing"), std::string::npos);
  EXPECT_NE(error("RFC-4800:serial=4294967296").find("serial"), std::string::npos);
  EXPECT_NE(error("RFC-4800:lss=v2").find("default|v1|v3|none"), std::string::npos);
  EXPECT_NE(error("RFC-4800:segmented=yes").find("on|off"), std::string::npos);
  EXPECT_NE(error("RFC-4800:colour=red").find("unknown key 'colour'"), std::string::npos);
  EXPECT_NE(error(":node=1").find("model"), std::string::npos);
  EXPECT_NE(error("RFC-4800:motion=wobble:3").find("motion"), std::string::npos);
}

}  // namespace
}  // namespace cobridge::sim
