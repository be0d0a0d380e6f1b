// The cobridge-sim control protocol: one line in, one command (or an error
// naming what is allowed) out.
#include "app/control_command.hpp"

#include <gtest/gtest.h>

namespace cobridge::sim {
namespace {

ControlCommand ok(std::string_view line) {
  const auto p = parse_control_command(line);
  EXPECT_TRUE(p.command.has_value()) << line << ": " << p.error;
  return p.command.value_or(ControlCommand{});
}

std::string error(std::string_view line) {
  const auto p = parse_control_command(line);
  EXPECT_FALSE(p.command.has_value()) << line;
  return p.error;
}

TEST(ControlCommand, SimpleVerbs) {
  EXPECT_EQ(ok("list").verb, ControlVerb::list);
  EXPECT_EQ(ok("  quit \r").verb, ControlVerb::quit);
  EXPECT_EQ(ok("stats").verb, ControlVerb::stats);
  EXPECT_EQ(ok("help").verb, ControlVerb::help);
}

TEST(ControlCommand, DeviceCommands) {
  auto c = ok("power-cycle 0x12345678");
  EXPECT_EQ(c.verb, ControlVerb::power_cycle);
  EXPECT_EQ(c.serial, 0x12345678u);
  EXPECT_EQ(ok("power-off 3").verb, ControlVerb::power_off);
  EXPECT_EQ(ok("power-on 3").verb, ControlVerb::power_on);
  c = ok("silence 4 on");
  EXPECT_EQ(c.verb, ControlVerb::silence);
  EXPECT_TRUE(c.on);
  EXPECT_FALSE(ok("silence 4 off").on);
  c = ok("move 9 -0.25");
  EXPECT_EQ(c.verb, ControlVerb::move);
  EXPECT_DOUBLE_EQ(c.turns, -0.25);
}

// Fault kinds mirror FaultKind (E§9.1, J§1.8.1 causes).
TEST(ControlCommand, EveryFaultKindRoundTrips) {
  for (const FaultKind k : {FaultKind::measurement_error, FaultKind::over_range, FaultKind::under_range,
                            FaultKind::hardware_fault, FaultKind::temperature_high, FaultKind::temperature_low,
                            FaultKind::voltage_high, FaultKind::voltage_low, FaultKind::channel_disagreement,
                            FaultKind::clear}) {
    const auto c = ok("fault 1 " + std::string(to_string(k)));
    EXPECT_EQ(c.fault, k);
  }
  EXPECT_NE(error("fault 1 on-fire").find("measurement-error|over-range"), std::string::npos);
}

TEST(ControlCommand, BusCommands) {
  auto c = ok("flood vcan0 250");
  EXPECT_EQ(c.verb, ControlVerb::flood);
  EXPECT_EQ(c.iface, "vcan0");
  EXPECT_EQ(c.duration_ms, 250u);
  c = ok("babble vcan1 1A5 100");
  EXPECT_EQ(c.verb, ControlVerb::babble);
  EXPECT_EQ(c.cob_id, 0x1A5u);
  EXPECT_EQ(ok("babble vcan1 0x7ff 1").cob_id, 0x7FFu);
  c = ok("bus-error vcan0 bus-off");
  EXPECT_EQ(c.verb, ControlVerb::bus_error);
  EXPECT_EQ(c.bus_error, BusErrorKind::bus_off);
  EXPECT_EQ(ok("bus-error vcan0 error-passive").bus_error, BusErrorKind::error_passive);
  EXPECT_EQ(ok("bus-error vcan0 restarted").bus_error, BusErrorKind::restarted);
}

TEST(ControlCommand, ErrorsNameWhatIsAllowed) {
  EXPECT_NE(error("").find("empty"), std::string::npos);
  EXPECT_NE(error("explode").find("unknown command 'explode'"), std::string::npos);
  EXPECT_NE(error("power-cycle").find("usage: power-cycle <serial>"), std::string::npos);
  EXPECT_NE(error("power-cycle x1").find("serial"), std::string::npos);
  EXPECT_NE(error("silence 1 maybe").find("on|off"), std::string::npos);
  EXPECT_NE(error("flood vcan0 0").find("1..3600000"), std::string::npos);
  EXPECT_NE(error("babble vcan0 XYZ 10").find("cob-id"), std::string::npos);
  EXPECT_NE(error("bus-error vcan0 meltdown").find("error-passive|error-active|bus-off"), std::string::npos);
  EXPECT_NE(error("move 1 abc").find("turns"), std::string::npos);
  EXPECT_NE(error("list extra").find("usage"), std::string::npos);
}

}  // namespace
}  // namespace cobridge::sim
