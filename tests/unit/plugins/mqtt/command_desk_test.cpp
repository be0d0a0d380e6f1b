// CommandDesk: a DCMD becomes a daemon command (plugin ABI 2,
// submit_command) only under the write policy; every refusal and every
// outcome comes back as a result with a code and words, and only our own
// COMMAND samples (by tag) are taken as outcomes.
#include "command_desk.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <vector>

namespace cobridge::mqtt {
namespace {

DcmdRequest request(std::uint8_t kind, std::int64_t value = 0) {
  DcmdRequest r;
  std::strcpy(r.device_id, "rot");
  std::strcpy(r.client, "scada-1");
  r.kind = kind;
  r.value = value;
  return r;
}

cobridge_sample outcome(std::uint32_t tag, std::uint16_t device, std::uint8_t status) {
  cobridge_sample s{};
  s.kind = COBRIDGE_SAMPLE_COMMAND;
  s.valid = COBRIDGE_VALID_COMMAND;
  s.device_index = device;
  s.command_tag = tag;
  s.command_status = status;
  s.command_abort_code = status == COBRIDGE_COMMAND_REFUSED ? 0x06090030u : 0u;
  return s;
}

class CommandDeskTest : public ::testing::Test {
 protected:
  CommandDesk make(bool enabled, int answer = COBRIDGE_COMMAND_OK) {
    WritePolicy p;
    p.enabled = enabled;
    return CommandDesk(
        p,
        [this, answer](const cobridge_command& c) {
          submitted.push_back(c);
          return answer;
        },
        [this](int, const std::string& m) { logged.push_back(m); });
  }
  std::vector<cobridge_command> submitted;
  std::vector<std::string> logged;
};

TEST_F(CommandDeskTest, RefusedWithWritesDisabledNothingSubmitted) {
  CommandDesk d = make(false);
  const auto r = d.on_dcmd(request(COBRIDGE_COMMAND_PRESET, 5), 0, "rot");
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->code, static_cast<std::int32_t>(CommandRefusal::kWritesDisabled));
  EXPECT_NE(r->text.find("writes are disabled"), std::string::npos);
  EXPECT_EQ(r->client, "scada-1");
  EXPECT_TRUE(submitted.empty());
  ASSERT_FALSE(logged.empty());
  EXPECT_NE(logged.back().find("client 'scada-1'"), std::string::npos);  // logged with its sender
}

TEST_F(CommandDeskTest, AcceptedThenItsOutcomeByTag) {
  CommandDesk d = make(true);
  EXPECT_FALSE(d.on_dcmd(request(COBRIDGE_COMMAND_PRESET, 1234), 3, "rot").has_value());
  ASSERT_EQ(submitted.size(), 1u);
  const cobridge_command& c = submitted[0];
  EXPECT_EQ(c.kind, COBRIDGE_COMMAND_PRESET);
  EXPECT_EQ(c.value, 1234);
  EXPECT_EQ(c.device_index, 3u);
  EXPECT_EQ(c.struct_size, sizeof(cobridge_command));
  EXPECT_EQ(c.tag & 0xFFFF0000u, CommandDesk::kTagMark);
  // Another output's command (Modbus tags count from 0) is not ours.
  EXPECT_FALSE(d.on_sample(outcome(c.tag & 0xFFFFu, 3, COBRIDGE_COMMAND_OK)).has_value());
  const auto r = d.on_sample(outcome(c.tag, 3, COBRIDGE_COMMAND_OK));
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->code, 0);
  EXPECT_EQ(r->text, "done");
  EXPECT_EQ(r->device_index, 3u);
  EXPECT_FALSE(d.on_sample(outcome(c.tag, 3, COBRIDGE_COMMAND_OK)).has_value());  // once
}

TEST_F(CommandDeskTest, DeviceAbortReportedWithItsCode) {
  CommandDesk d = make(true);
  (void)d.on_dcmd(request(COBRIDGE_COMMAND_STORE), 0, "rot");
  const auto r = d.on_sample(outcome(submitted.at(0).tag, 0, COBRIDGE_COMMAND_REFUSED));
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->code, COBRIDGE_COMMAND_REFUSED);
  EXPECT_NE(r->text.find("0x06090030"), std::string::npos);
}

TEST_F(CommandDeskTest, DaemonRefusalNowIsPublishedWithItsStatus) {
  CommandDesk d = make(true, COBRIDGE_COMMAND_OFFLINE);
  const auto r = d.on_dcmd(request(COBRIDGE_COMMAND_NMT_RESET), 1, "rot");
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->code, COBRIDGE_COMMAND_OFFLINE);
  EXPECT_NE(r->text.find("offline"), std::string::npos);
}

TEST_F(CommandDeskTest, MalformedAndForeignAliasRefused) {
  CommandDesk d = make(true);
  DcmdRequest bad = request(0);
  std::strcpy(bad.error, "metric 'X' is not a command");
  auto r = d.on_dcmd(bad, 0, "rot");
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->code, static_cast<std::int32_t>(CommandRefusal::kMalformed));
  EXPECT_NE(r->text.find("'X'"), std::string::npos);
  DcmdRequest other = request(COBRIDGE_COMMAND_STORE);
  other.alias_device = 4;
  r = d.on_dcmd(other, 0, "rot");
  ASSERT_TRUE(r.has_value());
  EXPECT_NE(r->text.find("another device"), std::string::npos);
  EXPECT_TRUE(submitted.empty());
  EXPECT_FALSE(d.on_dcmd(request(COBRIDGE_COMMAND_STORE), -1, "").has_value());  // no device: log only
  EXPECT_NE(logged.back().find("unknown device 'rot'"), std::string::npos);
}

TEST_F(CommandDeskTest, NoCommandApiRefused) {
  WritePolicy p;
  p.enabled = true;
  CommandDesk d(p, nullptr, [](int, const std::string&) {});
  const auto r = d.on_dcmd(request(COBRIDGE_COMMAND_STORE), 0, "rot");
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->code, static_cast<std::int32_t>(CommandRefusal::kNoCommands));
}

}  // namespace
}  // namespace cobridge::mqtt
