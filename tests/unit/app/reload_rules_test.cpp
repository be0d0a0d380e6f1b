// app/reload_rules: what a SIGHUP reload may change while the daemon runs
// (docs/operations.md, "Reload"): the devices and logging may change; the
// buses, the state file, the control socket, [web] and the outputs may not.
#include "app/reload_rules.hpp"

#include <gtest/gtest.h>

namespace {

using cobridge::app::reload_refusal;
using namespace cobridge::config;

Config running() {
  Config c;
  c.gateway.state_dir = "/var/lib/cobridge";
  c.gateway.control_socket = "/run/cobridge/control.sock";
  Bus b;
  b.name = "line1";
  b.interface = "can0";
  c.buses.push_back(b);
  Output o;
  o.name = "tap";
  o.settings_toml = "path = \"/tmp/x\"\n";
  c.outputs.push_back(o);
  c.web = WebSettings{};
  return c;
}

TEST(ReloadRules, DevicesAndLoggingMayChange) {
  Config next = running();
  next.devices.emplace_back().name = "lift";
  next.logging.level = LogLevel::debug;
  EXPECT_EQ(reload_refusal(running(), next), "");
}

TEST(ReloadRules, BusesStayOpen) {
  Config next = running();
  next.buses[0].interface = "can1";
  EXPECT_EQ(reload_refusal(running(), next), "bus line1 (can0) became line1 (can1)");
  next = running();
  next.buses.push_back(next.buses[0]);
  EXPECT_EQ(reload_refusal(running(), next), "the number of [[bus]] tables changed");
}

// docs/configuration.md [[bus]] recorder_seconds: the ring is sized at start.
TEST(ReloadRules, TheFlightRecorderKeepsItsStartSettings) {
  Config next = running();
  next.buses[0].recorder_seconds = 30;
  EXPECT_EQ(reload_refusal(running(), next),
            "bus line1: the flight recorder's settings (recorder_seconds, capture_after_s, capture_cap_mib, "
            "capture_budget_per_hour) take a "
            "restart");
  next = running();
  next.buses[0].capture_cap_mib = 1;
  EXPECT_NE(reload_refusal(running(), next), "");
}

TEST(ReloadRules, StateFileAndControlSocketStayWhereTheyAre) {
  Config next = running();
  next.gateway.state_dir = "/srv/cobridge";
  EXPECT_EQ(reload_refusal(running(), next), "gateway.state_dir changed");
  next = running();
  next.gateway.control_socket = "/run/other.sock";
  EXPECT_EQ(reload_refusal(running(), next), "gateway.control_socket changed");
}

TEST(ReloadRules, WebAndOutputsRunWithTheirStartSettings) {
  Config next = running();
  next.web->port = 9999;
  EXPECT_EQ(reload_refusal(running(), next), "[web] changed");
  next = running();
  next.web.reset();
  EXPECT_EQ(reload_refusal(running(), next), "[web] changed");
  next = running();
  next.web->hosts = std::vector<std::string>{"gw1.plant.local"};
  EXPECT_EQ(reload_refusal(running(), next), "[web] changed") << "web.hosts";
  next = running();
  next.outputs[0].settings_toml = "path = \"/tmp/y\"\n";
  EXPECT_EQ(reload_refusal(running(), next), "[outputs.tap] changed");
}

// The first refusal is reported: the buses before anything else.
TEST(ReloadRules, FirstRefusalWins) {
  Config next = running();
  next.buses[0].name = "line2";
  next.gateway.state_dir = "/srv/cobridge";
  EXPECT_EQ(reload_refusal(running(), next), "bus line1 (can0) became line2 (can0)");
}

}  // namespace
