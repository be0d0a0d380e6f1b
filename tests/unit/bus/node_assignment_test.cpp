// Node-ID assignment (the pure decision of discovery): every target, clash
// and swap case of discovery/node_assignment.hpp, with no bus and no clock.
// CiA 305 leaves the choice of node-ID to the LSS master's application; the
// rules checked here are the ones the header states (config -> remembered
// table -> session -> node_pool; swap policy same-model; unknown_devices).
#include "bus/discovery/node_assignment.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace cobridge::bus::discovery {
namespace {

constexpr std::uint32_t kNovotechnik = 0x182;
constexpr std::uint32_t kRfc4800 = 0x0BE0;
constexpr std::uint32_t kMultiturn = 0x0BB8;

LssAddress rotary(std::uint32_t serial, std::uint32_t rev = 0x00010003) {
  return {kNovotechnik, kRfc4800, rev, serial};
}
LssAddress multiturn(std::uint32_t serial) { return {kNovotechnik, kMultiturn, 0x00010005, serial}; }

class NodeAssignmentTest : public ::testing::Test {
 protected:
  NodeAssignmentTest() {
    bus.name = "b";
    bus.node_pool = {10, 11, 12};
  }
  config::Device& device(std::string name, std::uint32_t serial, std::optional<std::uint8_t> node,
                         std::string model = "RFC-4800") {
    config::Device d;
    d.name = std::move(name);
    d.serial = serial;
    d.node_id = node;
    d.model = std::move(model);
    devices.push_back(d);
    return devices.back();
  }
  void at(std::uint8_t n, const LssAddress& a) {
    picture[n].ids = {a};
    picture[n].last = {a};
  }
  void remembered(const LssAddress& a, std::uint8_t node) {
    previous.push_back(Assignment{"b", a.serial, a.vendor, a.product, a.revision, node, ""});
  }
  AssignmentInput input() const { return AssignmentInput{bus, devices, previous, picture, session, done, round}; }
  Decision decide_(const LssAddress& a) const { return decide(a, input()); }

  config::Bus bus;
  std::vector<config::Device> devices;
  std::vector<Assignment> previous;
  BusPicture picture{};
  Session session;
  bool done = true;    // the start-up probe is over
  bool round = false;  // no probe round running
};

// ---- targets -----------------------------------------------------------------

TEST_F(NodeAssignmentTest, ConfiguredSerialGetsItsConfiguredNodeId) {
  device("a", 1001, 5);
  const Decision d = decide_(rotary(1001));
  EXPECT_EQ(d.target, 5);
  EXPECT_EQ(d.device, "a");
  EXPECT_TRUE(d.problem.empty());
  EXPECT_FALSE(d.wait);
}

TEST_F(NodeAssignmentTest, WrongModelIsReportedAndGetsNoTarget_J1_2_1_E4_1) {
  device("a", 1001, 5, "MZ1-2200");
  const Decision d = decide_(rotary(1001));
  EXPECT_EQ(d.target, 0);
  EXPECT_EQ(d.device, "a");
  EXPECT_NE(d.problem.find("wrong model"), std::string::npos);
  auto& v = device("b", 1002, 6, "");
  v.vendor = 0x69666D;  // ifm
  EXPECT_EQ(decide_(rotary(1002)).target, 0);
}

TEST_F(NodeAssignmentTest, WithoutNodeIdTheRememberedOneIsKept) {
  device("a", 1001, std::nullopt);
  remembered(rotary(1001), 42);
  EXPECT_EQ(decide_(rotary(1001)).target, 42);
}

TEST_F(NodeAssignmentTest, RememberedLineOfAnotherVendorIsNotTaken) {
  auto& c = device("a", 1001, std::nullopt);
  c.vendor = kNovotechnik;
  remembered(LssAddress{0x69666D, 1, 0, 1001}, 42);
  EXPECT_EQ(decide_(rotary(1001)).target, 10);  // the pool's first node
}

TEST_F(NodeAssignmentTest, PromiseOfThisSessionComesBeforeThePool) {
  device("a", 1001, std::nullopt);
  session.assigned.emplace_back(rotary(1001), 12);
  EXPECT_EQ(decide_(rotary(1001)).target, 12);
}

TEST_F(NodeAssignmentTest, PoolSkipsConfiguredRememberedPresentAndPromisedNodes) {
  device("a", 1001, std::nullopt);
  device("b", 1002, 10);                             // configured for another device
  remembered(rotary(3000), 11);                      // remembered for another serial
  at(12, multiturn(4000));                           // held by a present device
  bus.node_pool = {10, 11, 12, 13, 14};
  session.assigned.emplace_back(multiturn(5000), 13);  // promised to another device
  EXPECT_EQ(decide_(rotary(1001)).target, 14);
}

TEST_F(NodeAssignmentTest, PoolSkipsAnUnpairedClashNode_CiA305) {
  device("a", 1001, std::nullopt);
  picture[10].clash = true;  // several devices answer, their identities not paired up
  EXPECT_EQ(decide_(rotary(1001)).target, 11);
}

TEST_F(NodeAssignmentTest, PoolExhaustedIsAProblem) {
  device("a", 1001, std::nullopt);
  bus.node_pool = {10};
  at(10, multiturn(4000));
  const Decision d = decide_(rotary(1001));
  EXPECT_EQ(d.target, 0);
  EXPECT_EQ(d.problem, "node pool exhausted for a");
}

TEST_F(NodeAssignmentTest, NodeFreeForEveryOccupancyCase_CiA305) {
  const LssAddress a = rotary(1001);
  EXPECT_FALSE(node_free_for(0, a, picture, session));    // not a node-ID
  EXPECT_FALSE(node_free_for(128, a, picture, session));  // not a node-ID
  EXPECT_TRUE(node_free_for(5, a, picture, session));
  at(5, rotary(1001, 0x99));  // the same device, another revision reported
  EXPECT_TRUE(node_free_for(5, a, picture, session));
  at(6, rotary(2002));
  EXPECT_FALSE(node_free_for(6, a, picture, session));
  picture[7].clash = true;  // unpaired clash
  EXPECT_FALSE(node_free_for(7, a, picture, session));
  picture[8].clash = true;  // paired clash of which `a` is one
  picture[8].ids = {a, rotary(2003)};
  EXPECT_FALSE(node_free_for(8, a, picture, session));
  session.assigned.emplace_back(rotary(2004), 9);
  EXPECT_FALSE(node_free_for(9, a, picture, session));
  session.assigned.emplace_back(a, 9);
  EXPECT_FALSE(node_free_for(9, a, picture, session));  // still promised to the other
  session.assigned.emplace_back(a, 20);
  EXPECT_TRUE(node_free_for(20, a, picture, session));
}

// ---- unknown devices -----------------------------------------------------------

TEST_F(NodeAssignmentTest, UnknownSerialWithSwapOffIsLeftAlone_J1_2_2) {
  bus.swap_policy = config::SwapPolicy::off;
  device("a", 1001, 5);  // absent
  const Decision d = decide_(rotary(9999));
  EXPECT_EQ(d.target, 0);
  EXPECT_TRUE(d.device.empty());
  EXPECT_NE(d.problem.find("not in the configuration"), std::string::npos);
}

TEST_F(NodeAssignmentTest, UnknownSerialOfAnotherModelIsLeftAlone) {
  device("a", 1001, 5);  // absent, a rotary
  const Decision d = decide_(multiturn(9999));
  EXPECT_EQ(d.target, 0);
  EXPECT_FALSE(d.effects.swap);
}

TEST_F(NodeAssignmentTest, ConfigWithoutModelInformationTakesNoReplacement) {
  device("a", 1001, 5, "");  // nothing says which model it is
  const Decision d = decide_(rotary(9999));
  EXPECT_EQ(d.target, 0);
  EXPECT_FALSE(d.effects.swap);
}

// ---- swap policy same-model ----------------------------------------------------

TEST_F(NodeAssignmentTest, UnknownSerialTakesTheOneAbsentDevicesPlace_E3_1) {
  device("a", 1001, 5);
  remembered(rotary(1001, 0x7), 5);
  const Decision d = decide_(rotary(9999));
  EXPECT_EQ(d.target, 5);
  EXPECT_EQ(d.device, "a");
  EXPECT_EQ(d.replaces, "a");
  EXPECT_EQ(d.replaced, rotary(1001, 0x7));  // from the remembered line, revision included
  ASSERT_TRUE(d.effects.swap);
  EXPECT_EQ(d.effects.swap->by, rotary(9999));
  EXPECT_EQ(d.effects.unswap, "a");
  ASSERT_TRUE(d.effects.forget);
  EXPECT_EQ(d.effects.forget->serial, 1001u);
}

TEST_F(NodeAssignmentTest, SwapGivesUpTheOldPromiseBeforeChoosingFromThePool_E3_1) {
  device("a", 1001, std::nullopt);
  bus.node_pool = {10};
  session.assigned.emplace_back(rotary(1001), 10);  // promised to the missing device
  const Decision d = decide_(rotary(9999));
  EXPECT_EQ(d.target, 10);
  EXPECT_EQ(d.replaces, "a");
}

TEST_F(NodeAssignmentTest, SwapWaitsUntilTheStartUpProbeIsOver_E3_1) {
  device("a", 1001, 5);
  done = false;
  const Decision d = decide_(rotary(9999));
  EXPECT_TRUE(d.wait);
  EXPECT_EQ(d.target, 0);
  EXPECT_FALSE(d.effects.swap);
}

TEST_F(NodeAssignmentTest, SwapWaitsForTheProbeOfAnUnsupervisedNode_E3_1) {
  device("a", 1001, 5);
  at(5, rotary(1001));
  picture[5].unsure = true;  // its heartbeat was lost, not probed since
  const Decision d = decide_(rotary(9999));
  EXPECT_TRUE(d.wait);
  EXPECT_EQ(d.effects.probes, std::vector<std::uint8_t>{5});
  EXPECT_FALSE(d.effects.swap);
}

TEST_F(NodeAssignmentTest, SupervisedDeviceIsPresentEvenWhenAProbeMissedIt_E3_1) {
  device("a", 1001, 5);
  picture[5].last = {rotary(1001)};  // a probe in a silence found nobody
  picture[5].supervised = true;      // but its heartbeat is fine
  const Decision d = decide_(rotary(9999));
  EXPECT_EQ(d.target, 0);
  EXPECT_FALSE(d.wait);
  EXPECT_FALSE(d.effects.swap);
}

TEST_F(NodeAssignmentTest, DeviceInAnUnpairedClashIsPresent_CiA305) {
  auto& c = device("a", 1001, 5);
  c.vendor = kNovotechnik;
  picture[127].clash = true;
  picture[127].seen[0].add(kNovotechnik);
  picture[127].seen[3].add(1001);
  picture[127].seen[3].add(1002);
  EXPECT_FALSE(decide_(rotary(9999)).effects.swap);
}

TEST_F(NodeAssignmentTest, TwoAbsentOfTheModelAreReportedNotGuessed_E3_1) {
  device("a", 1001, 5);
  device("b", 1002, 6);
  const Decision d = decide_(rotary(9999));
  EXPECT_EQ(d.target, 0);
  EXPECT_FALSE(d.effects.swap);
  EXPECT_NE(d.problem.find("missing devices a, b"), std::string::npos);
}

TEST_F(NodeAssignmentTest, SwapWaitsForTheEndOfTheRunningProbeRound_E3_1) {
  device("a", 1001, 5);
  round = true;
  const Decision d = decide_(rotary(9999));
  EXPECT_TRUE(d.wait);
  EXPECT_TRUE(d.effects.recheck);
  EXPECT_FALSE(d.effects.swap);
}

TEST_F(NodeAssignmentTest, ReplacementDecidedAgainKeepsThePlace_E3_1) {
  device("a", 1001, 5);
  session.swapped.push_back(Swap{"a", rotary(9999), rotary(1001)});
  const Decision d = decide_(rotary(9999));
  EXPECT_EQ(d.target, 5);
  EXPECT_EQ(d.replaces, "a");
  EXPECT_EQ(d.replaced, rotary(1001));
  EXPECT_FALSE(d.effects.swap);
}

TEST_F(NodeAssignmentTest, ReplacementAfterARestartUsesItsOwnRememberedLine_E3_1) {
  device("a", 1001, std::nullopt);
  remembered(rotary(9999), 33);  // the state file since the swap
  session.swapped.push_back(Swap{"a", rotary(9999), rotary(1001)});
  EXPECT_EQ(decide_(rotary(9999)).target, 33);
}

TEST_F(NodeAssignmentTest, OriginalBackWhileTheReplacementIsPresentIsLeftAlone_E3_1) {
  device("a", 1001, 5);
  session.swapped.push_back(Swap{"a", rotary(9999), rotary(1001)});
  at(5, rotary(9999));
  const Decision d = decide_(rotary(1001));
  EXPECT_EQ(d.target, 0);
  EXPECT_TRUE(d.device.empty());
  EXPECT_NE(d.problem.find("is back"), std::string::npos);
}

TEST_F(NodeAssignmentTest, OriginalBackWhileTheReplacementIsUnsureWaits_E3_1) {
  device("a", 1001, 5);
  session.swapped.push_back(Swap{"a", rotary(9999), rotary(1001)});
  at(5, rotary(9999));
  picture[5].unsure = true;
  const Decision d = decide_(rotary(1001));
  EXPECT_TRUE(d.wait);
  EXPECT_EQ(d.effects.probes, std::vector<std::uint8_t>{5});
}

TEST_F(NodeAssignmentTest, OriginalBackAfterTheReplacementLeftTakesItsPlaceBack_E3_1) {
  device("a", 1001, 5);
  session.swapped.push_back(Swap{"a", rotary(9999), rotary(1001)});
  session.assigned.emplace_back(rotary(9999), 5);
  const Decision d = decide_(rotary(1001));
  EXPECT_EQ(d.target, 5);
  EXPECT_EQ(d.device, "a");
  EXPECT_EQ(d.replaces, "a");
  EXPECT_EQ(d.replaced, rotary(9999));
  EXPECT_EQ(d.effects.unswap, "a");
  ASSERT_TRUE(d.effects.forget);
  EXPECT_EQ(d.effects.forget->serial, 9999u);
}

// ---- non-configured (FFh) devices found by a scan ------------------------------

TEST_F(NodeAssignmentTest, FoundConfiguredDeviceGoesToItsTarget_CiA305_Fastscan) {
  device("a", 1001, 5);
  const Placement p = place_non_configured(rotary(1001), 0, true, input());
  EXPECT_EQ(p.via, Placement::Via::decision);
  EXPECT_EQ(p.target, 5);
}

TEST_F(NodeAssignmentTest, FoundDeviceWhoseTargetIsHeldGoesBackToTheClashNode_CiA305) {
  device("a", 1001, 5);
  at(5, rotary(2002));
  const Placement p = place_non_configured(rotary(1001), 127, true, input());
  EXPECT_EQ(p.via, Placement::Via::back);
  EXPECT_EQ(p.target, 127);
}

TEST_F(NodeAssignmentTest, FoundStrangerStaysNonConfiguredUnderIgnore) {
  const Placement p = place_non_configured(multiturn(7), 0, true, input());
  EXPECT_EQ(p.via, Placement::Via::none);
  EXPECT_EQ(p.target, 0);
  EXPECT_FALSE(p.decision.problem.empty());
}

TEST_F(NodeAssignmentTest, FoundStrangerGetsAPoolNodeUnderAssign) {
  bus.unknown_devices = config::UnknownDevices::assign;
  at(10, rotary(2002));
  const Placement p = place_non_configured(multiturn(7), 0, true, input());
  EXPECT_EQ(p.via, Placement::Via::pool);
  EXPECT_EQ(p.target, 11);
  EXPECT_TRUE(p.decision.problem.empty());  // reported by the move instead
}

TEST_F(NodeAssignmentTest, FoundStrangerGetsItsRememberedNodeUnderAssign) {
  bus.unknown_devices = config::UnknownDevices::assign;
  remembered(multiturn(7), 40);
  const Placement p = place_non_configured(multiturn(7), 0, true, input());
  EXPECT_EQ(p.via, Placement::Via::pool);
  EXPECT_EQ(p.target, 40);
}

TEST_F(NodeAssignmentTest, FoundStrangerWithThePoolUsedUpUnderAssign) {
  bus.unknown_devices = config::UnknownDevices::assign;
  bus.node_pool = {10};
  at(10, rotary(2002));
  const Placement p = place_non_configured(multiturn(7), 0, true, input());
  EXPECT_EQ(p.via, Placement::Via::none);
  EXPECT_TRUE(p.pool_exhausted);
}

TEST_F(NodeAssignmentTest, SlowscanFindIsNotGivenAPoolNode_J1_5) {
  bus.unknown_devices = config::UnknownDevices::assign;
  const Placement p = place_non_configured(rotary(7), 0, false, input());
  EXPECT_EQ(p.via, Placement::Via::none);
  EXPECT_FALSE(p.pool_exhausted);
}

TEST_F(NodeAssignmentTest, InputIsNotChanged) {
  device("a", 1001, 5);
  session.assigned.emplace_back(rotary(1001), 5);
  const Decision d = decide_(rotary(9999));
  ASSERT_TRUE(d.effects.swap);
  EXPECT_EQ(session.assigned.size(), 1u);  // the caller records the effects
  EXPECT_TRUE(session.swapped.empty());
}

}  // namespace
}  // namespace cobridge::bus::discovery
