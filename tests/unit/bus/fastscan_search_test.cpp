// Fastscan search (discovery/fastscan_search): which CiA 305 searches look
// for the non-configured devices, and the back-off of the general Fastscan
// for devices nobody configured. No bus: the plans are checked as tasks.
#include "bus/discovery/fastscan_search.hpp"

#include <gtest/gtest.h>

#include <chrono>

namespace cobridge::bus::discovery {
namespace {

using namespace std::chrono_literals;

constexpr std::uint32_t kNovotechnik = 0x182;

BusSettings settings(std::vector<config::Device> devices) {
  BusSettings s;
  s.devices = std::move(devices);
  return s;
}

config::Device device(std::string name, std::uint32_t serial, std::string model) {
  config::Device d;
  d.name = std::move(name);
  d.serial = serial;
  d.model = std::move(model);
  return d;
}

// The general Fastscan runs when it may; its plan holds
// the configured device not present (vendor of its model, one target per
// product code, serial configured; revision unknown, searched), the model
// for a new device of it, and searches the rest. Rotary devices (no
// Fastscan, J§1 intro) are left out.
TEST(FastscanSearchTest, GuidedPlanOfAbsentConfiguredDevices_CiA305_BitChecked0) {
  Report report;
  FastscanSearch search(report);
  const BusSettings devices = settings({device("mt", 77, "MZ1-2200"), device("rot", 5, "RFC-4800")});
  const BusPicture picture{};
  const auto v = search.searches(canopen::TimePoint{} + 1h, devices, picture);
  ASSERT_EQ(v.size(), 1u);
  EXPECT_EQ(v.front().op, Op::fastscan_loop);
  const auto targeted = FastscanSearch::plan(false, devices, picture, {}, {});
  ASSERT_GE(targeted.size(), 1u);
  for (std::size_t i = 0; i < targeted.size(); ++i) {
    EXPECT_EQ(targeted.target(i).field[0], kNovotechnik);
    EXPECT_NE(targeted.target(i).field[1], std::nullopt);
    EXPECT_EQ(targeted.target(i).field[2], std::nullopt);  // unknown: searched bit by bit
    EXPECT_EQ(targeted.target(i).field[3], 77u);
  }
  EXPECT_FALSE(targeted.search_unknown);
  const auto general = FastscanSearch::plan(true, devices, picture, {}, {});
  EXPECT_GT(general.size(), targeted.size());
  EXPECT_TRUE(general.search_unknown);
  // Found in this run already: not guessed again.
  EXPECT_EQ(FastscanSearch::plan(false, devices, picture, {}, {LssAddress{kNovotechnik, 0x0BB8, 1, 77}}).size(), 0u);
}

TEST(FastscanSearchTest, PresentDeviceIsNotLookedFor) {
  Report report;
  FastscanSearch search(report);
  const BusSettings devices = settings({device("mt", 77, "MZ1-2200")});
  BusPicture picture{};
  picture[5].ids = {LssAddress{kNovotechnik, 0x0BB8, 1, 77}};
  EXPECT_EQ(FastscanSearch::plan(false, devices, picture, {}, {}).size(), 0u);
}

TEST(FastscanSearchTest, StrangerReportedOnceAndGeneralScanBacksOff) {
  Report report;
  FastscanSearch search(report);
  const LssAddress stranger{0x1234, 1, 1, 9};
  search.note_stranger(stranger, "not in the configuration");
  search.note_stranger(stranger, "not in the configuration");
  EXPECT_TRUE(search.is_stranger(stranger));
  EXPECT_EQ(report.take_events().size(), 2u);  // one problem + one identified at FFh
  const canopen::TimePoint t0 = canopen::TimePoint{} + 1h;
  search.back_off(t0, 10s);
  EXPECT_TRUE(search.searches(t0 + 9s, BusSettings{}, BusPicture{}).empty());
  ASSERT_EQ(search.searches(t0 + 10s, BusSettings{}, BusPicture{}).size(), 1u);
  search.back_off(t0, 10s);  // again: 2 * 10 s + 10 s
  EXPECT_TRUE(search.searches(t0 + 29s, BusSettings{}, BusPicture{}).empty());
  for (int i = 0; i < 10; ++i) search.back_off(t0, 10s);
  EXPECT_EQ(search.searches(t0 + 10min, BusSettings{}, BusPicture{}).size(), 1u);  // at most 10 min
}

TEST(FastscanSearchTest, SlowscanOnlyForThePreFastscanProductsSeen_J1_2_1) {
  IdentityAnswers seen;
  seen[0].add(kNovotechnik);
  seen[1].add(0x0BE0);  // RFC-4800: pre-Fastscan
  seen[1].add(0x0BB8);  // multiturn: Fastscan
  const auto v = FastscanSearch::slowscan_of(seen, 127, false);
  ASSERT_EQ(v.size(), 1u);
  EXPECT_EQ(v[0].op, Op::slowscan_loop);
  EXPECT_EQ(v[0].range.product, 0x0BE0u);
  EXPECT_EQ(v[0].node, 127);
  EXPECT_EQ(FastscanSearch::slowscan_all_pre_fastscan().size(), 5u);
}

}  // namespace
}  // namespace cobridge::bus::discovery
