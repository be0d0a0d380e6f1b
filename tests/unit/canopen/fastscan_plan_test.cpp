// FastscanPlan: which value a CiA 305 Fastscan confirms whole next, and when
// it may fall back to the bit-by-bit search.
#include <gtest/gtest.h>

#include <vector>

#include "canopen/fastscan_plan.hpp"

namespace cobridge::canopen {
namespace {

constexpr uint8_t kVendor = 0, kProduct = 1, kRevision = 2, kSerial = 3;

std::vector<uint32_t> candidates(const FastscanPlan& p, const LssAddress& settled, uint8_t field) {
  std::vector<uint32_t> out;
  FastscanPlan::Tried tried = 0;
  while (auto v = p.next_candidate(settled, field, tried)) out.push_back(*v);
  return out;
}

// The value shared by most targets first: one confirm decides for all of
// them; each value is offered once.
TEST(FastscanPlan, CiA305_MostSharedValueFirstEachOnce) {
  FastscanPlan p;
  p.add(FastscanTarget::of(0x69666D, 0x4341, std::nullopt, 3001));
  p.add(FastscanTarget::of(0x182, 0x0BB8, std::nullopt, 2001));
  p.add(FastscanTarget::of(0x182, 0x0BB8, std::nullopt, 2002));
  p.add(FastscanTarget::of(0x182, 0x0BC0, std::nullopt, 2003));
  EXPECT_EQ(candidates(p, {}, kVendor), (std::vector<uint32_t>{0x182, 0x69666D}));
  EXPECT_EQ(candidates(p, {0x182, 0, 0, 0}, kProduct), (std::vector<uint32_t>{0x0BB8, 0x0BC0}));
  EXPECT_EQ(candidates(p, {0x69666D, 0, 0, 0}, kProduct), (std::vector<uint32_t>{0x4341}));
  // Revision unknown in every target: no guess, searched.
  EXPECT_TRUE(candidates(p, {0x182, 0x0BB8, 0, 0}, kRevision).empty());
  EXPECT_TRUE(p.may_search({0x182, 0x0BB8, 0, 0}, kRevision));
  // Serials only of the targets consistent with what was settled.
  EXPECT_EQ(candidates(p, {0x182, 0x0BB8, 0x10003, 0}, kSerial), (std::vector<uint32_t>{2001, 2002}));
  EXPECT_EQ(candidates(p, {0x182, 0x0BC0, 0x10003, 0}, kSerial), (std::vector<uint32_t>{2003}));
}

// Every field known in every target: nothing may be searched unless the plan
// says so (a targeted scan ends with "not found" after a wrong guess).
TEST(FastscanPlan, CiA305_SearchOnlyWhereSomethingIsUnknown) {
  FastscanPlan p;
  p.add(FastscanTarget::of(0x182, 0x0BB8, 0x10003, 2001));
  EXPECT_FALSE(p.may_search({}, kVendor));
  EXPECT_FALSE(p.may_search({0x182, 0x0BB8, 0x10003, 0}, kSerial));
  p.add(FastscanTarget::of(0x182, 0x0BB8, std::nullopt, std::nullopt));  // a model: serial unknown
  EXPECT_FALSE(p.may_search({}, kVendor));
  EXPECT_TRUE(p.may_search({0x182, 0x0BB8, 0x10003, 0}, kSerial));
  EXPECT_FALSE(p.may_search({0x999, 0x0BB8, 0x10003, 0}, kSerial));  // not consistent with that model
  p.search_unknown = true;
  EXPECT_TRUE(p.may_search({0x999, 0, 0, 0}, kProduct));
}

// An empty plan guesses nothing; a full plan keeps every slave findable by
// turning the search on.
TEST(FastscanPlan, EmptyAndFull) {
  FastscanPlan p;
  EXPECT_TRUE(candidates(p, {}, kVendor).empty());
  EXPECT_FALSE(p.may_search({}, kVendor));
  for (uint32_t s = 0; s < FastscanPlan::kMaxTargets; ++s) EXPECT_TRUE(p.add(FastscanTarget::of(1, 2, 3, s)));
  EXPECT_TRUE(p.add(FastscanTarget::of(1, 2, 3, 0)));  // a duplicate is not a new target
  EXPECT_FALSE(p.search_unknown);
  EXPECT_FALSE(p.add(FastscanTarget::of(1, 2, 3, 999)));
  EXPECT_TRUE(p.search_unknown);
  EXPECT_EQ(p.size(), FastscanPlan::kMaxTargets);
}

}  // namespace
}  // namespace cobridge::canopen
