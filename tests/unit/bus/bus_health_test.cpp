// BusHealthGate (docs/plugins.md "on_bus"): a transition of the CAN
// controller's state (ISO 11898-1 fault confinement, Linux can.rst) or of
// the interface goes to the outputs at once, moving counters at most once
// per period.
#include "bus/bus_health.hpp"

#include <gtest/gtest.h>

namespace cobridge::bus {
namespace {

using namespace std::chrono_literals;
using canopen::kNever;
using canopen::TimePoint;

BusHealth health(can::ControllerState s, std::uint16_t tx) {
  BusHealth h;
  h.open = true;
  h.controller.state = s;
  h.controller.source = can::HealthSource::error_frames;
  h.controller.counters_known = true;
  h.controller.tx_errors = tx;
  return h;
}

TEST(BusHealthGate, TransitionsAtOnceCountersAtMostOncePerPeriod) {
  BusHealthGate gate(1s);
  const TimePoint t0{10s};
  EXPECT_TRUE(gate.due(health(can::ControllerState::error_active, 0), t0)) << "the first is told";
  EXPECT_FALSE(gate.due(health(can::ControllerState::error_active, 0), t0 + 10ms)) << "nothing new";
  EXPECT_EQ(gate.next(), kNever);
  EXPECT_FALSE(gate.due(health(can::ControllerState::error_active, 8), t0 + 20ms)) << "counters: held back";
  EXPECT_EQ(gate.next(), t0 + 1s);
  EXPECT_FALSE(gate.due(health(can::ControllerState::error_active, 16), t0 + 500ms));
  EXPECT_TRUE(gate.due(health(can::ControllerState::error_active, 24), t0 + 1s)) << "the latest, a period later";
  EXPECT_EQ(gate.next(), kNever);
  EXPECT_TRUE(gate.due(health(can::ControllerState::error_warning, 96), t0 + 1s + 1ms)) << "a transition: at once";
  EXPECT_TRUE(gate.due(health(can::ControllerState::error_passive, 128), t0 + 1s + 2ms)) << "and the next one too";
  BusHealth closed = health(can::ControllerState::error_passive, 128);
  closed.open = false;
  EXPECT_TRUE(gate.due(closed, t0 + 1s + 3ms)) << "the interface went down";
}

}  // namespace
}  // namespace cobridge::bus
