// RestoreGuard (docs/reliability.md "A writer that keeps changing a
// configured object"): restores of one object wait longer each time, a
// drift after three restores within ten minutes makes the object contested,
// and only an operator's acknowledgement lets it be written again.
#include "bus/restore_guard.hpp"

#include <gtest/gtest.h>

namespace cobridge::bus {
namespace {

using namespace std::chrono_literals;
using canopen::TimePoint;
using Verdict = RestoreGuard::Verdict;

TEST(RestoreGuard, FirstRestoreAtOnceThenBackoff) {
  RestoreGuard g;
  const TimePoint t{1000s};
  auto d = g.on_drift(0x1017, 0, t);
  EXPECT_EQ(d.verdict, Verdict::restore);
  EXPECT_EQ(d.not_before, t);
  EXPECT_EQ(d.restores, 1u);
  d = g.on_drift(0x1017, 0, t + 1s);
  EXPECT_EQ(d.verdict, Verdict::restore);
  EXPECT_EQ(d.not_before, t + 1s + 5s);
  d = g.on_drift(0x1017, 0, t + 7s);
  EXPECT_EQ(d.verdict, Verdict::restore);
  EXPECT_EQ(d.not_before, t + 7s + 20s);
  EXPECT_EQ(d.restores, 3u);
  EXPECT_FALSE(g.any_contested());
}

// A writer setting 0x1017 every 2 s for 40 s met 18 restores before; now
// it meets three, and the fourth drift makes the object contested.
TEST(RestoreGuard, FourthDriftWithinTheWindowIsContested) {
  RestoreGuard g;
  const TimePoint t{1000s};
  unsigned restores = 0;
  unsigned contested = 0;
  for (int s = 0; s <= 40; s += 2) {
    const auto d = g.on_drift(0x1017, 0, t + std::chrono::seconds(s));
    restores += d.verdict == Verdict::restore ? 1U : 0U;
    contested += d.verdict == Verdict::contested ? 1U : 0U;
  }
  EXPECT_EQ(restores, 3u);
  EXPECT_EQ(contested, 1u) << "contested once; later drifts are held";
  EXPECT_TRUE(g.contested(0x1017, 0));
  EXPECT_FALSE(g.contested(0x1017, 1));
  EXPECT_EQ(g.on_drift(0x1017, 0, t + 41s).verdict, Verdict::held);
}

TEST(RestoreGuard, RestoresOlderThanTheWindowNoLongerCount) {
  RestoreGuard g;
  const TimePoint t{1000s};
  (void)g.on_drift(0x6003, 0, t);
  (void)g.on_drift(0x6003, 0, t + 60s);
  (void)g.on_drift(0x6003, 0, t + 120s);
  // The first restore left the 10-minute window: a fourth is granted, after
  // the third wait (two restores remain in the window).
  const auto d = g.on_drift(0x6003, 0, t + 601s);
  EXPECT_EQ(d.verdict, Verdict::restore);
  EXPECT_EQ(d.restores, 3u);
  EXPECT_EQ(d.not_before, t + 601s + 20s);
}

TEST(RestoreGuard, ObjectsAreCountedApart) {
  RestoreGuard g;
  const TimePoint t{1000s};
  for (int i = 0; i < 4; ++i) (void)g.on_drift(0x1017, 0, t + std::chrono::seconds(i));
  EXPECT_TRUE(g.contested(0x1017, 0));
  const auto d = g.on_drift(0x1800, 5, t + 5s);
  EXPECT_EQ(d.verdict, Verdict::restore);
  EXPECT_EQ(d.not_before, t + 5s) << "another object's first restore is at once";
}

TEST(RestoreGuard, AcknowledgeStartsTheCountsOver) {
  RestoreGuard g;
  const TimePoint t{1000s};
  for (int i = 0; i < 4; ++i) (void)g.on_drift(0x1017, 0, t + std::chrono::seconds(i));
  EXPECT_EQ(g.acknowledge(), 1u);
  EXPECT_FALSE(g.any_contested());
  const auto d = g.on_drift(0x1017, 0, t + 10s);
  EXPECT_EQ(d.verdict, Verdict::restore);
  EXPECT_EQ(d.not_before, t + 10s);
  EXPECT_EQ(g.acknowledge(), 0u) << "nothing contested";
}

}  // namespace
}  // namespace cobridge::bus
