// What MosquittoLink reads from the broker: the primary host's STATE (spec
// 5, Sparkplug 3.0 JSON payload) and NCMD Node Control/Rebirth (spec 6.4).
#include "mosquitto_link.hpp"
#include "sparkplug_payload.hpp"

#include <gtest/gtest.h>

#include <array>

namespace cobridge::mqtt {
namespace {

TEST(StatePayload, Spec5_OnlineMemberOfTheJsonPayload) {
  EXPECT_EQ(parse_state_online(R"({"online": true, "timestamp": 1668114759262})"), 1);
  EXPECT_EQ(parse_state_online(R"({"timestamp":1,"online":false})"), 0);
  EXPECT_EQ(parse_state_online("OFFLINE"), -1);  // Sparkplug 2.2's plain text: not 3.0
  EXPECT_EQ(parse_state_online(R"({"online": "yes"})"), -1);
}

// A STATE older than the last one heard is not followed: its timestamp says which is newer.
TEST(StatePayload, Spec5_TimestampMemberOfTheJsonPayload) {
  EXPECT_EQ(parse_state_timestamp(R"({"online": true, "timestamp": 1668114759262})"), 1668114759262);
  EXPECT_EQ(parse_state_timestamp(R"({"timestamp" :7,"online":false})"), 7);
  EXPECT_EQ(parse_state_timestamp(R"({"online": true})"), -1);
  EXPECT_EQ(parse_state_timestamp(R"({"online": true, "timestamp": "soon"})"), -1);
  EXPECT_EQ(parse_state_timestamp(R"({"online": true, "timestamp": -5})"), -1);
}

std::size_t ncmd(std::array<std::uint8_t, 256>& buf, const char* name, std::uint64_t alias, bool value) {
  PayloadBuilder b;
  b.begin(1, std::uint8_t{0});
  EXPECT_TRUE(b.add_scalar(name, alias, 1, DataType::kBoolean, Scalar{value ? 1 : 0, 0.0}));
  return b.pack(buf);
}

TEST(NcmdPayload, Spec6_RebirthByNameOrAlias) {
  std::array<std::uint8_t, 256> buf{};
  std::size_t n = ncmd(buf, "Node Control/Rebirth", 0, true);
  EXPECT_TRUE(ncmd_requests_rebirth(buf.data(), n));
  n = ncmd(buf, nullptr, kRebirthAlias, true);
  EXPECT_TRUE(ncmd_requests_rebirth(buf.data(), n));
  n = ncmd(buf, "Node Control/Rebirth", 0, false);
  EXPECT_FALSE(ncmd_requests_rebirth(buf.data(), n));
  n = ncmd(buf, "Node Control/Reboot", 0, true);
  EXPECT_FALSE(ncmd_requests_rebirth(buf.data(), n));
  const std::uint8_t junk[] = {0xFF, 0xFF, 0xFF};
  EXPECT_FALSE(ncmd_requests_rebirth(junk, sizeof junk));
}

}  // namespace
}  // namespace cobridge::mqtt
