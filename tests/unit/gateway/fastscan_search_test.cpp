// Fastscan search (discovery/fastscan_search): which CiA 305 searches look
// for the non-configured devices, and the back-off of the general Fastscan
// for devices nobody configured. No bus: the plans are checked as tasks.
#include "gateway/discovery/fastscan_search.hpp"

#include <gtest/gtest.h>

#include <chrono>

namespace cobridge::gateway::discovery {
namespace {

using namespace std::chrono_literals;

constexpr std::uint32_t kNovotechnik = 0x182;

config::Device device(std::string name, std::uint32_t serial, std::string model) {
  config::Device d;
  d.name = std::move(name);
  d.serial = serial;
  d.model = std::move(model);
  return d;
}

TEST(FastscanSearchTest, TargetedFastscanPerProductCodeOfTheModelThenGeneral_CiA305_BitChecked0) {
  Report report;
  FastscanSearch search(report);
  const std::vector<config::Device> devices{device("mt", 77, "MZ1-2200")};
  const BusPicture picture{};
  const auto v = search.searches(canopen::TimePoint{} + 1h, devices, picture);
  ASSERT_GE(v.size(), 2u);
  for (std::size_t i = 0; i + 1 < v.size(); ++i) {
    EXPECT_EQ(v[i].op, Op::fastscan_known);
    EXPECT_EQ(v[i].ctx.identity.vendor, kNovotechnik);
    EXPECT_EQ(v[i].ctx.identity.serial, 77u);
    EXPECT_EQ(v[i].ctx.device, "mt");
  }
  EXPECT_EQ(v.back().op, Op::fastscan_loop);
  const auto k = FastscanSearch::known_fields(v.front().ctx.identity);
  EXPECT_EQ(k.serial, 77u);
  EXPECT_FALSE(k.revision);  // unknown: searched bit by bit
}

TEST(FastscanSearchTest, PresentDeviceIsNotSearched) {
  Report report;
  FastscanSearch search(report);
  const std::vector<config::Device> devices{device("mt", 77, "MZ1-2200")};
  BusPicture picture{};
  picture[5].ids = {LssAddress{kNovotechnik, 0x0BB8, 1, 77}};
  const auto v = search.searches(canopen::TimePoint{} + 1h, devices, picture);
  ASSERT_EQ(v.size(), 1u);
  EXPECT_EQ(v.front().op, Op::fastscan_loop);
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
  EXPECT_TRUE(search.searches(t0 + 9s, {}, BusPicture{}).empty());
  ASSERT_EQ(search.searches(t0 + 10s, {}, BusPicture{}).size(), 1u);
  search.back_off(t0, 10s);  // again: 2 * 10 s + 10 s
  EXPECT_TRUE(search.searches(t0 + 29s, {}, BusPicture{}).empty());
  for (int i = 0; i < 10; ++i) search.back_off(t0, 10s);
  EXPECT_EQ(search.searches(t0 + 10min, {}, BusPicture{}).size(), 1u);  // at most 10 min
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
}  // namespace cobridge::gateway::discovery
