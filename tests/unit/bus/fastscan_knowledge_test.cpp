// make_fastscan_plan: what the configuration and the remembered table tell a
// CiA 305 Fastscan before it starts.
#include <gtest/gtest.h>

#include <vector>

#include "bus/fastscan_knowledge.hpp"

namespace cobridge::bus {
namespace {

using canopen::FastscanTarget;
using canopen::LssAddress;
using U32 = std::optional<std::uint32_t>;

config::Device device(std::string model, std::uint32_t serial) {
  config::Device d;
  d.name = model + "-" + std::to_string(serial);
  d.model = std::move(model);
  d.serial = serial;
  return d;
}

// A configured multiturn device (E§4.1: vendor 0x182; the MC1-2800 reports
// one of two product codes) not present at a node-ID: one target per
// product code, serial known, revision unknown until remembered.
TEST(FastscanKnowledge, AbsentConfiguredDeviceOneTargetPerProductCode) {
  const config::Device mt = device("MC1-2800", 2001);
  FastscanKnowledge k;
  k.absent = {&mt};
  auto p = make_fastscan_plan(k);
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p.target(0).field, (FastscanTarget::of(0x182, 0x0BB8, std::nullopt, 2001).field));
  EXPECT_EQ(p.target(1).field, (FastscanTarget::of(0x182, 0x0BB9, std::nullopt, 2001).field));
  EXPECT_FALSE(p.search_unknown);

  // Remembered (state file): product and revision seen before -> whole identity.
  const std::vector<Assignment> remembered{{"line1", 2001, 0x182, 0x0BB9, 0x10003, 20, ""}};
  k.remembered = remembered;
  p = make_fastscan_plan(k);
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p.target(0).field, (FastscanTarget::of(0x182, 0x0BB9, 0x10003, 2001).field));
}

// A configured product code wins over the model's list; the ifm model names
// no product code (F§7.3), so its product stays unknown (searched).
TEST(FastscanKnowledge, ConfiguredProductAndIfmWithoutProductCode) {
  config::Device mt = device("MC1-2800", 2001);
  mt.product = 0x0BB9;
  const config::Device ifm = device("RM9", 3001);
  FastscanKnowledge k;
  k.absent = {&mt, &ifm};
  const auto p = make_fastscan_plan(k);
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p.target(0).field, (FastscanTarget::of(0x182, 0x0BB9, std::nullopt, 2001).field));
  EXPECT_EQ(p.target(1).field, (FastscanTarget::of(0x0069666D, std::nullopt, std::nullopt, 3001).field));
}

// Models a new device may be (swap, assign) leave the serial to the search;
// whole known identities come first; `general` searches the rest too.
TEST(FastscanKnowledge, ModelsKnownIdentitiesAndGeneral) {
  const config::Device rot = device("RFC-4800", 1001);
  FastscanKnowledge k;
  k.known = {LssAddress{0x182, 0x0BE0, 0x10003, 1002}};
  k.models = {&rot};
  k.general = true;
  const auto p = make_fastscan_plan(k);
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(p.target(0).field, (FastscanTarget::of(0x182, 0x0BE0, 0x10003, 1002).field));
  EXPECT_EQ(p.target(1).field, (FastscanTarget::of(0x182, 0x0BE0, std::nullopt, std::nullopt).field));
  EXPECT_TRUE(p.search_unknown);
}

// A same-model replacement (serial unknown) is guessed to have the revision
// remembered for its product: only the serial is then searched.
TEST(FastscanKnowledge, ModelGuessesTheRememberedRevision) {
  const config::Device rot = device("MC1-2800", 2001);
  const std::vector<Assignment> remembered{{"line1", 2001, 0x182, 0x0BB8, 0x10003, 20, ""}};
  FastscanKnowledge k;
  k.models = {&rot};
  k.remembered = remembered;
  const auto p = make_fastscan_plan(k);
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p.target(0).field, (FastscanTarget::of(0x182, 0x0BB8, 0x10003, std::nullopt).field));
  EXPECT_EQ(p.target(1).field, (FastscanTarget::of(0x182, 0x0BB8, std::nullopt, std::nullopt).field));
  EXPECT_EQ(p.target(2).field, (FastscanTarget::of(0x182, 0x0BB9, std::nullopt, std::nullopt).field));
}

// Factory-fresh devices of one delivery share a revision: once a Fastscan of
// this round has found one (or the table remembers one of the same vendor
// and product), a configured device whose revision is unknown is tried with
// that revision first (one CiA 305 confirm instead of 32 bit steps); the
// target with the revision unknown stays, so another revision is searched.
TEST(FastscanKnowledge, AbsentDeviceGuessesTheRevisionFoundInThisRound_CiA305_8_3_4) {
  const config::Device mt = device("MC1-2800", 2002);
  const std::vector<LssAddress> found{{0x182, 0x0BB8, 0x10003, 2001}};
  FastscanKnowledge k;
  k.absent = {&mt};
  k.found = found;
  const auto p = make_fastscan_plan(k);
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(p.target(0).field, (FastscanTarget::of(0x182, 0x0BB8, 0x10003, 2002).field));
  EXPECT_EQ(p.target(1).field, (FastscanTarget::of(0x182, 0x0BB8, std::nullopt, 2002).field));
  EXPECT_EQ(p.target(2).field, (FastscanTarget::of(0x182, 0x0BB9, std::nullopt, 2002).field));
  // The revision field: the guess first, and a bit search still allowed.
  canopen::FastscanPlan::Tried tried = 0;
  LssAddress settled{0x182, 0x0BB8, 0, 0};
  EXPECT_EQ(p.next_candidate(settled, 2, tried), U32(0x10003));
  EXPECT_TRUE(p.may_search(settled, 2));
}

// 32 configured devices with a guessed revision each fit one plan (64 targets).
TEST(FastscanKnowledge, ThirtyTwoDevicesWithGuessesFitOnePlan) {
  std::vector<config::Device> devices;
  for (std::uint32_t s = 9000; s < 9032; ++s) {
    devices.push_back(device("MC1-2800", s));
    devices.back().product = 0x0BB8;
  }
  const std::vector<LssAddress> found{{0x182, 0x0BB8, 0x10000, 8999}};
  FastscanKnowledge k;
  for (const auto& d : devices) k.absent.push_back(&d);
  k.found = found;
  const auto p = make_fastscan_plan(k);
  EXPECT_EQ(p.size(), 64u);
  EXPECT_FALSE(p.search_unknown);
}

// A device described by an EDS file (no vendor, no model configured): the
// file's VendorNumber is confirmed whole; the product is searched.
TEST(FastscanKnowledge, VendorFromTheDevicesEdsFile_CiA306_DeviceInfo) {
  config::Device custom;
  custom.name = "custom";
  custom.serial = 4242;
  custom.eds = "/etc/cobridge/custom.eds";
  const std::vector<std::pair<std::uint32_t, std::uint32_t>> eds_vendors{{4242, 0x0069666D}};
  FastscanKnowledge k;
  k.absent = {&custom};
  k.eds_vendors = eds_vendors;
  const auto p = make_fastscan_plan(k);
  ASSERT_EQ(p.size(), 1u);
  EXPECT_EQ(p.target(0).field, (FastscanTarget::of(0x0069666D, std::nullopt, std::nullopt, 4242).field));
  k.eds_vendors = {};
  EXPECT_EQ(make_fastscan_plan(k).target(0).field, (FastscanTarget::of(std::nullopt, std::nullopt, std::nullopt, 4242).field));
}

// The same device listed twice (absent, and as a model) yields no duplicate.
TEST(FastscanKnowledge, NoDuplicateTargets) {
  const config::Device a = device("RFC-4800", 1001), b = device("RFC-4800", 1002);
  FastscanKnowledge k;
  k.models = {&a, &b};
  EXPECT_EQ(make_fastscan_plan(k).size(), 1u);
}

}  // namespace
}  // namespace cobridge::bus
