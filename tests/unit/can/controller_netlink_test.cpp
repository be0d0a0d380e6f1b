// The controller's state and error counters as rtnetlink gives them (Linux
// can.rst "Netlink interface to set/get devices properties": IFLA_CAN_STATE
// with enum can_state of linux/can/netlink.h, IFLA_CAN_BERR_COUNTER), mapped
// to ISO 11898-1 fault confinement states and merged with what the error
// frames told; no socket (the reading is what libnl parsed). The read itself
// runs against vcan inside UML in vcan_daemon_bus_health, and here against
// the host's loopback (rtnetlink needs no CAN in the kernel).
#include "can/controller_netlink.hpp"

#include <linux/can/netlink.h>

#include <gtest/gtest.h>

namespace cobridge::can {
namespace {

NetlinkReading can_dev(std::uint32_t state, int tx = -1, int rx = 0) {
  NetlinkReading r;
  r.can_device = true;
  r.has_state = true;
  r.state = state;
  if (tx >= 0) {
    r.has_berr = true;
    r.tx_errors = static_cast<std::uint16_t>(tx);
    r.rx_errors = static_cast<std::uint16_t>(rx);
  }
  return r;
}

TEST(ControllerNetlink, CanRst_KernelStatesMapOneToOne) {
  EXPECT_EQ(to_controller_state(CAN_STATE_ERROR_ACTIVE), ControllerState::error_active);
  EXPECT_EQ(to_controller_state(CAN_STATE_ERROR_WARNING), ControllerState::error_warning);
  EXPECT_EQ(to_controller_state(CAN_STATE_ERROR_PASSIVE), ControllerState::error_passive);
  EXPECT_EQ(to_controller_state(CAN_STATE_BUS_OFF), ControllerState::bus_off);
  // Not a confinement state: the controller is not on the bus.
  EXPECT_EQ(to_controller_state(CAN_STATE_STOPPED), ControllerState::unknown);
  EXPECT_EQ(to_controller_state(CAN_STATE_SLEEPING), ControllerState::unknown);
  EXPECT_EQ(to_controller_state(99), ControllerState::unknown);
}

TEST(ControllerNetlink, CanRst_DriverStateAndBerrCounterBecomeTheHealth) {
  ControllerHealth h;
  EXPECT_TRUE(apply_netlink(h, can_dev(CAN_STATE_ERROR_PASSIVE, 135, 7), 100));
  EXPECT_EQ(h.state, ControllerState::error_passive);
  EXPECT_EQ(h.source, HealthSource::netlink);
  EXPECT_EQ(h.driver, DriverReport::state);
  EXPECT_TRUE(h.counters_known);
  EXPECT_EQ(h.tx_errors, 135);
  EXPECT_EQ(h.rx_errors, 7);
  EXPECT_EQ(h.since_ns, 100);
  // Counters above 255 (the kernel's are 16 bits) are kept as they are.
  EXPECT_TRUE(apply_netlink(h, can_dev(CAN_STATE_BUS_OFF, 256, 0), 200));
  EXPECT_EQ(h.tx_errors, 256);
  EXPECT_FALSE(apply_netlink(h, can_dev(CAN_STATE_BUS_OFF, 256, 0), 300)) << "no change";
  EXPECT_EQ(h.since_ns, 200);
}

TEST(ControllerNetlink, CanRst_StateWithoutBerrCounterLeavesCountersUnknown) {
  // A driver without do_get_berr_counter sends IFLA_CAN_STATE only.
  ControllerHealth h;
  EXPECT_TRUE(apply_netlink(h, can_dev(CAN_STATE_ERROR_ACTIVE), 1));
  EXPECT_EQ(h.state, ControllerState::error_active);
  EXPECT_FALSE(h.counters_known);
}

TEST(ControllerNetlink, Vcan_NoControllerStateIsSaidNotInvented) {
  ControllerHealth h;
  NetlinkReading vcan;  // link kind "vcan": no IFLA_INFO_DATA
  EXPECT_FALSE(apply_netlink(h, vcan, 1));
  EXPECT_EQ(h.driver, DriverReport::no_state);
  EXPECT_EQ(h.state, ControllerState::unknown);
  EXPECT_EQ(h.source, HealthSource::none);
  EXPECT_FALSE(h.counters_known);
  // Error frames (injected on vcan) still tell a state; netlink's silence keeps it.
  BusEvent ev;
  ev.kind = BusEventKind::ErrorPassive;
  EXPECT_TRUE(h.apply(ev));
  EXPECT_FALSE(apply_netlink(h, vcan, 2));
  EXPECT_EQ(h.state, ControllerState::error_passive);
  EXPECT_EQ(h.source, HealthSource::error_frames);
}

TEST(ControllerNetlink, CanRst_FramesRefreshNetlinkFiguresBetweenPolls) {
  ControllerHealth h;
  apply_netlink(h, can_dev(CAN_STATE_ERROR_ACTIVE, 10, 0), 1);
  BusEvent ev;
  ev.kind = BusEventKind::BusOff;
  EXPECT_TRUE(h.apply(ev));
  EXPECT_EQ(h.state, ControllerState::bus_off);
  EXPECT_EQ(h.source, HealthSource::netlink) << "netlink stays the source";
  // The adapter swapped for one whose driver says nothing: the old figures
  // are withdrawn, not shown as current.
  EXPECT_TRUE(apply_netlink(h, NetlinkReading{}, 3));
  EXPECT_EQ(h.state, ControllerState::unknown);
  EXPECT_EQ(h.source, HealthSource::none);
  EXPECT_FALSE(h.counters_known);
}

// RTM_GETLINK of a link that is not a can-dev one (loopback, like vcan):
// read, but no controller data.
TEST(ControllerNetlink, RtnetlinkLoopbackIsReadAsNotACanDevice) {
  ControllerNetlink nl;
  const auto r = nl.read("lo");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_FALSE(r->can_device);
  EXPECT_FALSE(r->has_state);
  EXPECT_FALSE(r->has_berr);
  const auto again = nl.read("lo");  // the socket is kept and reused
  EXPECT_TRUE(again.ok());
}

// A missing interface (an adapter unplugged) is an error that names it.
TEST(ControllerNetlink, MissingInterfaceIsNotFoundAndNamed) {
  ControllerNetlink nl;
  const auto r = nl.read("nocan9");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().kind, Errc::kNotFound) << r.error().message;
  EXPECT_EQ(r.error().where, "interface nocan9");
  EXPECT_NE(r.error().message.find("RTM_GETLINK"), std::string::npos) << r.error().message;
}

}  // namespace
}  // namespace cobridge::can
