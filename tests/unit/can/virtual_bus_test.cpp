// can::VirtualBus: broadcast semantics of a CAN bus for the layers' unit tests
// (ISO 11898-1: every node sees every frame; SocketCAN's default is that the
// sender does not receive its own frame, kernel can.rst "CAN_RAW_RECV_OWN_MSGS").
#include "can/virtual_bus.hpp"

#include <gtest/gtest.h>

namespace {

using cobridge::can::Frame;
using cobridge::can::FrameSink;
using cobridge::can::VirtualBus;

// ISO 11898-1 broadcast; can.rst CAN_RAW_RECV_OWN_MSGS default off.
TEST(VirtualBus, FrameReachesEveryOtherPortButNotTheSender) {
  VirtualBus bus;
  VirtualBus::Port& a = bus.attach();
  VirtualBus::Port& b = bus.attach();
  VirtualBus::Port& c = bus.attach();
  const Frame f = Frame::make(0x701, {0x05});
  ASSERT_TRUE(a.send(f));
  Frame got;
  ASSERT_TRUE(b.receive(got));
  EXPECT_EQ(got, f);
  ASSERT_TRUE(c.receive(got));
  EXPECT_EQ(got, f);
  EXPECT_FALSE(a.receive(got));
  EXPECT_FALSE(b.receive(got));
  ASSERT_EQ(bus.log().size(), 1u);
  EXPECT_EQ(bus.log()[0], f);
}

// Frames keep their order per receiver, as on the wire.
TEST(VirtualBus, OrderIsPreservedAcrossSenders) {
  VirtualBus bus;
  VirtualBus::Port& a = bus.attach();
  VirtualBus::Port& b = bus.attach();
  VirtualBus::Port& r = bus.attach();
  FrameSink& sa = a;  // used through the interface the services see
  ASSERT_TRUE(sa.send(Frame::make(0x1, {1})));
  ASSERT_TRUE(b.send(Frame::make(0x2, {2})));
  ASSERT_TRUE(sa.send(Frame::make(0x3, {3})));
  EXPECT_EQ(r.pending(), 3u);
  Frame got;
  for (uint32_t id : {0x1u, 0x2u, 0x3u}) {
    ASSERT_TRUE(r.receive(got));
    EXPECT_EQ(got.id, id);
  }
  EXPECT_EQ(a.pending(), 1u);  // only b's frame
  EXPECT_EQ(b.pending(), 2u);  // only a's two frames
}

TEST(VirtualBus, BlockedPortRefusesAndCounts) {
  VirtualBus bus;
  VirtualBus::Port& a = bus.attach();
  VirtualBus::Port& b = bus.attach();
  a.set_send_blocked(true);
  EXPECT_FALSE(a.send(Frame::make(0x80, {})));
  EXPECT_EQ(a.tx_refused(), 1u);
  EXPECT_EQ(a.stats().tx_dropped, 1u);  // one count, both names
  EXPECT_EQ(b.pending(), 0u);
  EXPECT_TRUE(bus.log().empty());
  a.set_send_blocked(false);
  EXPECT_TRUE(a.send(Frame::make(0x80, {})));
  EXPECT_EQ(b.pending(), 1u);
}

// A bounded port behaves like a full socket receive queue: later frames are dropped and counted.
TEST(VirtualBus, BoundedPortDropsWhenFull) {
  VirtualBus bus;
  VirtualBus::Port& a = bus.attach();
  VirtualBus::Port& small = bus.attach(2);
  for (uint8_t i = 0; i < 5; ++i) ASSERT_TRUE(a.send(Frame::make(0x180, {i})));
  EXPECT_EQ(small.pending(), 2u);
  EXPECT_EQ(small.rx_dropped(), 3u);
  Frame got;
  ASSERT_TRUE(small.receive(got));
  EXPECT_EQ(got.data[0], 0);  // the oldest survive
}

}  // namespace
