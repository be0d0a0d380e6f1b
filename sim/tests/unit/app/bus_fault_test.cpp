// Bus-level faults: Linux CAN error frames as the kernel documents them
// (<linux/can/error.h>, "Network Problem Notifications") and the flood/babble
// generator. The frames are checked by decoding them with the gateway's own
// decoder, so simulator and gateway agree on the layout.
#include "app/bus_fault.hpp"

#include "can/bus_event.hpp"

#include <linux/can/error.h>

#include <gtest/gtest.h>

#include <array>

namespace cobridge::sim {
namespace {

std::vector<can::BusEventKind> kinds(BusErrorKind k) {
  std::array<can::BusEvent, can::kMaxEventsPerErrorFrame> ev{};
  const std::size_t n = can::decode_error_frame(make_error_frame(k), ev);
  std::vector<can::BusEventKind> out;
  for (std::size_t i = 0; i < n; ++i) out.push_back(ev[i].kind);
  return out;
}

TEST(BusFault, ErrorPassiveFrameLayout) {
  const can::Frame f = make_error_frame(BusErrorKind::error_passive);
  EXPECT_TRUE(f.is_error());
  EXPECT_EQ(f.len, CAN_ERR_DLC);
  EXPECT_EQ(f.id, static_cast<std::uint32_t>(CAN_ERR_CRTL | CAN_ERR_CNT));
  EXPECT_EQ(f.data[1], CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE);
  EXPECT_EQ(f.data[6], 128);
  EXPECT_EQ(kinds(BusErrorKind::error_passive), std::vector<can::BusEventKind>{can::BusEventKind::ErrorPassive});
}

TEST(BusFault, BusOffAndRestartedDecode) {
  EXPECT_EQ(make_error_frame(BusErrorKind::bus_off).id, static_cast<std::uint32_t>(CAN_ERR_BUSOFF));
  EXPECT_EQ(kinds(BusErrorKind::bus_off), std::vector<can::BusEventKind>{can::BusEventKind::BusOff});
  EXPECT_EQ(kinds(BusErrorKind::restarted), std::vector<can::BusEventKind>{can::BusEventKind::Restarted});
  EXPECT_EQ(kinds(BusErrorKind::error_active), std::vector<can::BusEventKind>{can::BusEventKind::ErrorActive});
  EXPECT_EQ(kinds(BusErrorKind::error_warning), std::vector<can::BusEventKind>{can::BusEventKind::ErrorWarning});
}

TEST(BusFault, KindNamesRoundTrip) {
  for (const BusErrorKind k : {BusErrorKind::error_warning, BusErrorKind::error_passive, BusErrorKind::error_active,
                               BusErrorKind::bus_off, BusErrorKind::restarted})
    EXPECT_EQ(parse_bus_error_kind(to_string(k)), k);
  EXPECT_FALSE(parse_bus_error_kind("bus-on").has_value());
}

// CiA 301 §7.2.8.3.1: an NMT frame needs DLC 2, so the flood's DLC 0 on
// identifier 0 takes the bus without commanding anybody.
TEST(BusFault, FloodIsIdentifierZeroForItsDuration) {
  TrafficGenerator g;
  const canopen::TimePoint t0{std::chrono::seconds(10)};
  std::array<can::Frame, 4> out{};
  EXPECT_EQ(g.burst(t0, out), 0u);
  EXPECT_EQ(g.process(t0), canopen::kNever);
  g.start_flood(t0, std::chrono::milliseconds(50));
  EXPECT_TRUE(g.flooding(t0));
  EXPECT_EQ(g.process(t0), t0);
  ASSERT_EQ(g.burst(t0, out), 4u);
  for (const can::Frame& f : out) {
    EXPECT_EQ(f.id, 0u);
    EXPECT_EQ(f.len, 0);
  }
  EXPECT_TRUE(g.active(t0 + std::chrono::milliseconds(49)));
  EXPECT_FALSE(g.active(t0 + std::chrono::milliseconds(50)));
  EXPECT_EQ(g.burst(t0 + std::chrono::milliseconds(50), out), 0u);
}

TEST(BusFault, BabbleRepeatsOneIdentifierWithChangingData) {
  TrafficGenerator g;
  const canopen::TimePoint t0{std::chrono::seconds(1)};
  g.start_babble(0x1A5, t0, std::chrono::milliseconds(10));
  EXPECT_FALSE(g.flooding(t0));
  std::array<can::Frame, 2> out{};
  ASSERT_EQ(g.burst(t0, out), 2u);
  EXPECT_EQ(out[0].id, 0x1A5u);
  EXPECT_EQ(out[0].len, 8);
  EXPECT_FALSE(out[0].is_extended());
  EXPECT_NE(out[0].data, out[1].data);
  g.start_babble(0x12345, t0, std::chrono::milliseconds(10));
  ASSERT_EQ(g.burst(t0, out), 2u);
  EXPECT_TRUE(out[0].is_extended());
}

}  // namespace
}  // namespace cobridge::sim
