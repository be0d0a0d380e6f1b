// ElectionPeers: which node-IDs may be a gateway's in the master election,
// and which are live ("an election a stranger cannot
// steer"; CiA 302-2 priorities 0..2, CiA 301 node-IDs 1..127).
#include "canopen/election_peers.hpp"

#include <gtest/gtest.h>

namespace cobridge::canopen {
namespace {

using namespace std::chrono_literals;

constexpr Duration kTimeout = 150ms;  // 1.5 heartbeat periods of 100 ms

// CiA 301 7.2.8.3.1 node-IDs 1..127 and CiA 302-2 priorities 0..2; never our
// own node-ID nor an excluded one (a device's).
TEST(ElectionPeers, PlausibleOnlyForNodeIds1To127Priorities0To2NeverOursOrExcluded) {
  ElectionPeers p(120);
  NodeSet devices;
  devices.set(10);
  p.set_excluded(devices);
  EXPECT_TRUE(p.plausible(0, 121));
  EXPECT_TRUE(p.plausible(2, 1));
  EXPECT_TRUE(p.plausible(2, 127));
  EXPECT_FALSE(p.plausible(0, 0));
  EXPECT_FALSE(p.plausible(0, 128));
  EXPECT_FALSE(p.plausible(3, 121));
  EXPECT_FALSE(p.plausible(0, 120));
  EXPECT_FALSE(p.plausible(0, 10));
}

// Live: announced with that priority and heard within the timeout; a later
// exclusion (a reload naming the node a device) ends it.
TEST(ElectionPeers, LiveMeansAnnouncedWithThatPriorityAndHeardWithinTheTimeout) {
  ElectionPeers p(120);
  const TimePoint t0 = TimePoint{} + 1h;
  EXPECT_FALSE(p.live(0, 121, t0, kTimeout));  // never announced
  p.heard(121, t0);
  EXPECT_FALSE(p.live(0, 121, t0, kTimeout));  // heard, not announced
  EXPECT_TRUE(p.on_announce(0, 121, t0, kTimeout));
  EXPECT_TRUE(p.live(0, 121, t0 + 100ms, kTimeout));
  EXPECT_FALSE(p.live(1, 121, t0 + 100ms, kTimeout));  // not its priority
  EXPECT_FALSE(p.live(0, 121, t0 + 150ms, kTimeout));  // silent for the timeout
  EXPECT_TRUE(p.as_announced(0, 121));
  EXPECT_FALSE(p.as_announced(1, 121));
  EXPECT_TRUE(p.as_announced(1, 50));  // never announced: nothing to compare
  NodeSet devices;
  devices.set(121);
  p.set_excluded(devices);
  EXPECT_FALSE(p.live(0, 121, t0 + 100ms, kTimeout));
  EXPECT_FALSE(p.announced(121));
  EXPECT_EQ(p.peer(0), 0);
}

// Announcements that could not be a gateway's are not recorded.
TEST(ElectionPeers, AnImplausibleAnnouncementNamesNoGateway) {
  ElectionPeers p(120);
  const TimePoint t0 = TimePoint{} + 1h;
  EXPECT_FALSE(p.on_announce(7, 50, t0, kTimeout));
  EXPECT_FALSE(p.on_announce(0, 0, t0, kTimeout));
  EXPECT_FALSE(p.on_announce(0, 120, t0, kTimeout));
  EXPECT_FALSE(p.announced(50));
  EXPECT_FALSE(p.is_gateway(50, 0));
  EXPECT_FALSE(p.is_gateway(0, 0));
  EXPECT_TRUE(p.is_gateway(120, 0));  // ours
  EXPECT_EQ(p.peer(0), 0);
  EXPECT_TRUE(p.on_announce(1, 50, t0, kTimeout));
  EXPECT_EQ(p.peer(0), 50);
}

// A gateway's priority is its configuration's: while its heartbeat is heard
// another priority is not its own announcement (a forged 0x74 giving the
// peer priority 0, then a claim with it, took the role from the master);
// after 1.5 periods of silence (a restart) it counts.
TEST(ElectionPeers, AnotherPriorityCountsOnlyAfterTheGatewayFellSilent) {
  ElectionPeers p(120);
  const TimePoint t0 = TimePoint{} + 1h;
  ASSERT_TRUE(p.on_announce(1, 121, t0, kTimeout));
  p.heard(121, t0);
  EXPECT_FALSE(p.on_announce(0, 121, t0 + 100ms, kTimeout));
  EXPECT_TRUE(p.live(1, 121, t0 + 100ms, kTimeout));
  EXPECT_FALSE(p.live(0, 121, t0 + 100ms, kTimeout));
  EXPECT_TRUE(p.on_announce(1, 121, t0 + 100ms, kTimeout));  // the same: fine
  EXPECT_TRUE(p.on_announce(0, 121, t0 + 150ms, kTimeout));  // silent: restarted
  p.heard(121, t0 + 160ms);
  EXPECT_TRUE(p.live(0, 121, t0 + 200ms, kTimeout));
}

}  // namespace
}  // namespace cobridge::canopen
