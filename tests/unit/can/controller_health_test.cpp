// ControllerHealth (Linux can.rst "Network Problem Notifications"; ISO
// 11898-1 fault confinement): the state and counters the error frames tell.
#include "can/controller_health.hpp"

#include <gtest/gtest.h>

namespace cobridge::can {
namespace {

BusEvent event(BusEventKind kind, std::int64_t at, int tx = -1, int rx = -1) {
  BusEvent e;
  e.kind = kind;
  e.timestamp_ns = at;
  if (tx >= 0) {
    e.has_counters = true;
    e.tx_error_count = static_cast<std::uint8_t>(tx);
    e.rx_error_count = static_cast<std::uint8_t>(rx);
  }
  return e;
}

TEST(ControllerHealth, CanRst_StatesCountersAndRestarts) {
  ControllerHealth h;
  EXPECT_EQ(h.state, ControllerState::unknown) << "nothing told a state yet: not a guessed error-active";
  EXPECT_EQ(h.source, HealthSource::none);
  EXPECT_FALSE(h.counters_known);
  EXPECT_FALSE(h.apply(event(BusEventKind::ProtocolViolation, 5))) << "a bus error tells no state";
  EXPECT_EQ(h.source, HealthSource::none);
  EXPECT_TRUE(h.apply(event(BusEventKind::ErrorWarning, 10, 96, 0)));
  EXPECT_EQ(h.source, HealthSource::error_frames);
  EXPECT_EQ(to_string(h.source), "error frames");
  EXPECT_EQ(h.state, ControllerState::error_warning);
  EXPECT_TRUE(h.counters_known);
  EXPECT_EQ(h.tx_errors, 96);
  EXPECT_FALSE(h.apply(event(BusEventKind::ErrorWarning, 11, 100, 2))) << "no change of state";
  EXPECT_EQ(h.tx_errors, 100) << "but the counters follow";
  EXPECT_EQ(h.since_ns, 10);
  EXPECT_TRUE(h.apply(event(BusEventKind::ErrorPassive, 20, 128, 2)));
  EXPECT_TRUE(h.apply(event(BusEventKind::BusOff, 30)));
  EXPECT_EQ(to_string(h.state), "bus-off");
  EXPECT_FALSE(h.apply(event(BusEventKind::ProtocolViolation, 31)));
  EXPECT_EQ(h.bus_errors, 2u);
  EXPECT_TRUE(h.apply(event(BusEventKind::Restarted, 40, 0, 0)));
  EXPECT_EQ(h.state, ControllerState::error_active);
  EXPECT_EQ(h.restarts, 1u);
  EXPECT_EQ(h.since_ns, 40);
  EXPECT_FALSE(h.apply(event(BusEventKind::InterfaceDown, 50))) << "not a controller state";
}

}  // namespace
}  // namespace cobridge::can
