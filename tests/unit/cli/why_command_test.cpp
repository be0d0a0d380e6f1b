// `cobridge why`: which events of a device's timeline make the chain that led
// to its present state (docs/operations.md "Why a device is where it is").
#include "cli/why_command.hpp"

#include <gtest/gtest.h>

namespace cobridge::cli {
namespace {

Json timeline(const std::string& text) {
  Result<Json> parsed = JsonParser(text).parse();
  EXPECT_TRUE(parsed.ok());
  return parsed.ok() ? parsed.value() : Json{};
}

const char* kLife = R"js([
  {"kind":"state","text":"expected -> identified: identified (0x1018)"},
  {"kind":"state","text":"identified -> configuring: configuration plan started"},
  {"kind":"configured","text":"configured: 3 value(s) written and verified"},
  {"kind":"state","text":"configuring -> operational: configured and started"},
  {"kind":"emcy","text":"EMCY 0x5000: device hardware"},
  {"kind":"heartbeat","text":"heartbeat lost: none for 250 ms"},
  {"kind":"state","text":"operational -> offline: heartbeat lost: none for 250 ms"}
])js";

TEST(WhyChain, AnOfflineDeviceShowsWhatHappenedSinceItWasLastOperational) {
  // The EMCY came while it still ran: it belongs to the chain.
  EXPECT_EQ(chain_start(timeline(kLife), "offline"), 4U);
}

TEST(WhyChain, AnOperationalDeviceShowsItsWayBackSinceItLastLeft) {
  std::string text = kLife;
  text.pop_back();
  text += R"js(,{"kind":"boot_up","text":"boot-up message"},
    {"kind":"state","text":"offline -> identified: rebooted"},
    {"kind":"state","text":"identified -> operational: configured and started"}])js";
  // Everything after the previous entry into operational: the fault and the recovery.
  EXPECT_EQ(chain_start(timeline(text), "operational"), 4U);
}

TEST(WhyChain, ANeverOperationalDeviceShowsItsWholeTimeline) {
  const Json t = timeline(R"js([{"kind":"lss","text":"LSS step failed"},
    {"kind":"state","text":"expected -> failed: LSS step failed"}])js");
  EXPECT_EQ(chain_start(t, "failed"), 0U);
  EXPECT_EQ(chain_start(timeline(kLife), "operational"), 0U);  // operational once, never left
}

TEST(WhyChain, OnlyStateEventsEnteringOperationalCount) {
  // A text that mentions operational elsewhere is not an entry into it.
  const Json t = timeline(R"js([{"kind":"emcy","text":"x -> operational: not a state event"},
    {"kind":"state","text":"operational -> stopped: stopped by another NMT master"}])js");
  EXPECT_EQ(chain_start(t, "stopped"), 0U);
}

}  // namespace
}  // namespace cobridge::cli
