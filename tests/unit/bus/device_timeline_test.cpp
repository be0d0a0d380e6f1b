// A device's timeline (docs/operations.md "Why a device is where it is: the
// timeline"): the last 100 events, a storm of one event counted instead of
// pushing the cause out.
#include "bus/device_timeline.hpp"

#include <gtest/gtest.h>

namespace cobridge::bus {
namespace {

using namespace std::chrono_literals;
const std::chrono::system_clock::time_point kT0{std::chrono::seconds(1'800'000'000)};

TEST(DeviceTimeline, KeepsTheLastHundredEventsOldestFirst) {
  std::vector<TimelineEvent> tl;
  for (int i = 0; i < 150; ++i) {
    append_event(tl, TimelineEvent{kT0 + i * 1s, TimelineKind::state, "event " + std::to_string(i), {}});
  }
  ASSERT_EQ(tl.size(), kTimelineLength);
  EXPECT_EQ(tl.front().text, "event 50");
  EXPECT_EQ(tl.back().text, "event 149");
}

TEST(DeviceTimeline, AStormOfOneEventIsCountedNotAppended) {
  std::vector<TimelineEvent> tl;
  append_event(tl, TimelineEvent{kT0, TimelineKind::heartbeat, "heartbeat lost: none for 250 ms", "cap-1.log"});
  for (int i = 1; i <= 500; ++i) {
    append_event(tl, TimelineEvent{kT0 + i * 10ms, TimelineKind::emcy, "EMCY 0x50" + std::to_string(i % 10), {}});
  }
  ASSERT_EQ(tl.size(), 2U);  // the cause before the storm is still there
  EXPECT_EQ(tl[1].text, "EMCY 0x501");  // the storm's first names it
  EXPECT_EQ(tl[0].capture, "cap-1.log");
  EXPECT_EQ(tl[1].repeats, 500U);
  EXPECT_EQ(tl[1].at, kT0 + 10ms);
  EXPECT_EQ(tl[1].last_at, kT0 + 5000ms);
}

TEST(DeviceTimeline, TheSameEventLaterOrOfAnotherKindIsANewEntry) {
  std::vector<TimelineEvent> tl;
  append_event(tl, TimelineEvent{kT0, TimelineKind::state, "operational -> offline", {}});
  append_event(tl, TimelineEvent{kT0 + kTimelineRepeatWindow, TimelineKind::state, "operational -> offline", {}});
  append_event(tl, TimelineEvent{kT0 + kTimelineRepeatWindow, TimelineKind::heartbeat, "operational -> offline", {}});
  append_event(tl, TimelineEvent{kT0 + kTimelineRepeatWindow, TimelineKind::heartbeat, "heard again", {}});
  ASSERT_EQ(tl.size(), 4U);
  EXPECT_EQ(tl[0].repeats, 1U);
  EXPECT_EQ(tl[0].last_at, kT0);
}

// Status snapshots share the events: a copy made before an event keeps what it saw.
TEST(DeviceTimeline, ACopyKeepsTheEventsItWasMadeWith) {
  DeviceTimeline tl;
  EXPECT_TRUE(tl.empty());
  tl.add(TimelineEvent{kT0, TimelineKind::boot_up, "boot-up", {}});
  const DeviceTimeline snapshot = tl;
  EXPECT_EQ(&snapshot.events(), &tl.events());  // shared, not copied
  tl.add(TimelineEvent{kT0 + 1s, TimelineKind::state, "identified -> configuring", {}});
  ASSERT_EQ(snapshot.size(), 1U);
  ASSERT_EQ(tl.size(), 2U);
  EXPECT_EQ(tl.events().back().text, "identified -> configuring");
}

TEST(DeviceTimeline, KindsHaveTheirDocumentedNames) {
  EXPECT_STREQ(to_string(TimelineKind::boot_up), "boot-up");
  EXPECT_STREQ(to_string(TimelineKind::node_id), "node-id");
  EXPECT_STREQ(to_string(TimelineKind::drift), "drift");
  EXPECT_STREQ(to_string(TimelineKind::gateway), "gateway");
}

TEST(DeviceTimeline, EveryKindReadsBackFromItsName) {
  for (unsigned k = 0; k <= static_cast<unsigned>(TimelineKind::gateway); ++k) {
    TimelineKind back = TimelineKind::state;
    ASSERT_TRUE(parse_timeline_kind(to_string(static_cast<TimelineKind>(k)), back)) << k;
    EXPECT_EQ(static_cast<unsigned>(back), k);
  }
  TimelineKind back = TimelineKind::emcy;
  EXPECT_FALSE(parse_timeline_kind("Boot-up", back));
  EXPECT_FALSE(parse_timeline_kind("", back));
  EXPECT_EQ(back, TimelineKind::emcy);
}

TEST(DeviceTimeline, KeptEventsStartTheTimelineAndAreBoundedToo) {
  std::vector<TimelineEvent> kept;
  for (int i = 0; i < 120; ++i) kept.push_back(TimelineEvent{kT0 + i * 11s, TimelineKind::state, std::to_string(i), {}});
  DeviceTimeline tl(std::move(kept));
  ASSERT_EQ(tl.size(), kTimelineLength);
  EXPECT_EQ(tl.events().front().text, "20");
  tl.add(TimelineEvent{kT0 + 2000s, TimelineKind::gateway, "gateway started", {}});
  EXPECT_EQ(tl.size(), kTimelineLength);
  EXPECT_EQ(tl.events().back().kind, TimelineKind::gateway);
  EXPECT_TRUE(DeviceTimeline(std::vector<TimelineEvent>{}).empty());
}

}  // namespace
}  // namespace cobridge::bus
