// The timeline journal (issue "Why, at a glance", item 2: the timeline
// outlives a restart of the daemon): events read back as they were written,
// a storm costs one line per flush, the file stays bounded, and a damaged
// line is named and skipped.
#include "bus/timeline_journal.hpp"

#include <gtest/gtest.h>

#include "unit/support/temp_dir.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

namespace cobridge::gateway {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
const std::chrono::system_clock::time_point kT0{std::chrono::milliseconds(1'800'000'000'123)};

class TimelineJournalTest : public ::testing::Test {
 protected:
  std::size_t lines(const fs::path& p) const {
    std::ifstream in(p);
    std::size_t n = 0;
    for (std::string l; std::getline(in, l);) ++n;
    return n;
  }
  // `e` added to `tl` and noted in `j`, as BusManager::Impl::add_event does.
  static void add(TimelineJournal& j, const std::string& device, DeviceTimeline& tl, TimelineEvent e) {
    tl.add(std::move(e));
    j.note(device, tl.events().back());
  }
  test::TempDir tmp_{"journal-test"};
  const fs::path& dir_ = tmp_.path();
};

TEST_F(TimelineJournalTest, EventsReadBackAsTheyWereWritten) {
  TimelineJournal j(dir_, "line 1/a");
  EXPECT_EQ(j.path(), dir_ / "timelines" / "line%201%2Fa.timeline");
  DeviceTimeline lift;
  DeviceTimeline gate;
  add(j, "lift", lift, {kT0, TimelineKind::heartbeat, "heartbeat lost: none for 250 ms = 1 #x", "cap 1.log"});
  add(j, "gate", gate, {kT0 + 1s, TimelineKind::state, "operational -> offline: silent", {}});
  ASSERT_FALSE(j.flush({{"lift", lift}, {"gate", gate}}));
  EXPECT_FALSE(j.pending());

  std::map<std::string, std::vector<TimelineEvent>> back;
  TimelineJournal again(dir_, "line 1/a");
  ASSERT_FALSE(again.load(back));
  ASSERT_EQ(back.size(), 2U);
  ASSERT_EQ(back["lift"].size(), 1U);
  const TimelineEvent& e = back["lift"][0];
  EXPECT_EQ(e.at, kT0);  // to the millisecond
  EXPECT_EQ(e.kind, TimelineKind::heartbeat);
  EXPECT_EQ(e.text, "heartbeat lost: none for 250 ms = 1 #x");
  EXPECT_EQ(e.capture, "cap 1.log");
  EXPECT_EQ(back["gate"][0].text, "operational -> offline: silent");
}

TEST_F(TimelineJournalTest, AStormIsOneLinePerFlushAndItsCountSurvives) {
  TimelineJournal j(dir_, "line1");
  DeviceTimeline tl;
  for (int i = 0; i < 500; ++i) add(j, "lift", tl, {kT0 + i * 10ms, TimelineKind::emcy, "EMCY 0x5001", {}});
  ASSERT_FALSE(j.flush({{"lift", tl}}));
  EXPECT_EQ(lines(j.path()), 1U);
  for (int i = 500; i < 600; ++i) add(j, "lift", tl, {kT0 + i * 10ms, TimelineKind::emcy, "EMCY 0x5001", {}});
  ASSERT_FALSE(j.flush({{"lift", tl}}));
  EXPECT_EQ(lines(j.path()), 2U);  // the same event again, its count grown

  std::map<std::string, std::vector<TimelineEvent>> back;
  ASSERT_FALSE(TimelineJournal(dir_, "line1").load(back));
  ASSERT_EQ(back["lift"].size(), 1U);
  EXPECT_EQ(back["lift"][0].repeats, 600U);
  EXPECT_EQ(back["lift"][0].last_at, kT0 + 5990ms);
}

TEST_F(TimelineJournalTest, TheFileIsRewrittenOnceItHoldsFourTimesWhatIsKept) {
  TimelineJournal j(dir_, "line1");
  DeviceTimeline tl;
  for (int i = 0; i < 1000; ++i) {
    add(j, "lift", tl, {kT0 + i * 11s, TimelineKind::state, "event " + std::to_string(i), {}});
    ASSERT_FALSE(j.flush({{"lift", tl}}));
    ASSERT_LE(lines(j.path()), TimelineJournal::kCompactFactor * kTimelineLength);
  }
  std::map<std::string, std::vector<TimelineEvent>> back;
  ASSERT_FALSE(TimelineJournal(dir_, "line1").load(back));
  ASSERT_EQ(back["lift"].size(), kTimelineLength);
  EXPECT_EQ(back["lift"].front().text, "event 900");
  EXPECT_EQ(back["lift"].back().text, "event 999");
}

TEST_F(TimelineJournalTest, ADamagedLineIsNamedAndSkipped) {
  fs::create_directories(dir_ / "timelines");
  std::ofstream(dir_ / "timelines" / "line1.timeline")
      << "# header\n"
      << TimelineJournal::format_line("lift", {kT0, TimelineKind::boot_up, "boot-up", {}}) << "\n"
      << "at=x device=lift kind=state text=a\n"
      << "at=1 device=lift kind=nonsense text=a\n"
      << "at=1 kind=state text=a\n"
      << "garbage\n"
      << TimelineJournal::format_line("lift", {kT0 + 1s, TimelineKind::sdo, "SDO timeout", {}}) << " future=1\n"
      << "at=1 device=lift kind=state te";  // torn by a power cut
  std::map<std::string, std::vector<TimelineEvent>> back;
  const Error e = TimelineJournal(dir_, "line1").load(back);
  ASSERT_TRUE(e);
  EXPECT_EQ(e.kind, Errc::kInvalidArgument);
  const std::string file = (dir_ / "timelines" / "line1.timeline").string();
  EXPECT_NE(e.message.find(file + ":3: 'at' cannot be 'x'"), std::string::npos) << e.message;
  EXPECT_NE(e.message.find(file + ":4: 'kind' cannot be 'nonsense'"), std::string::npos) << e.message;
  EXPECT_NE(e.message.find(file + ":5: an event needs"), std::string::npos) << e.message;
  EXPECT_NE(e.message.find(file + ":6: expected key=value"), std::string::npos) << e.message;
  EXPECT_NE(e.message.find(file + ":8: expected key=value, got 'te'"), std::string::npos) << e.message;
  ASSERT_EQ(back["lift"].size(), 2U);  // the good lines, a newer gateway's extra field ignored
  EXPECT_EQ(back["lift"][1].text, "SDO timeout");
}

TEST_F(TimelineJournalTest, AFailedWriteKeepsTheEventsForTheNextTry) {
  fs::create_directories(dir_);
  std::ofstream(dir_ / "timelines") << "x";  // a file where the directory should be
  TimelineJournal j(dir_, "line1");
  DeviceTimeline tl;
  add(j, "lift", tl, {kT0, TimelineKind::boot_up, "boot-up", {}});
  const Error e = j.flush({{"lift", tl}});
  ASSERT_TRUE(e);
  EXPECT_EQ(e.where, j.path().string());
  EXPECT_TRUE(j.pending());
  fs::remove(dir_ / "timelines");
  ASSERT_FALSE(j.flush({{"lift", tl}}));
  EXPECT_EQ(lines(j.path()), 1U);
}

TEST_F(TimelineJournalTest, NoTimelinesNeverCompactTheHistoryAway) {
  TimelineJournal j(dir_, "line1");
  DeviceTimeline tl;
  for (int i = 0; i < 500; ++i) {
    add(j, "lift", tl, {kT0 + i * 11s, TimelineKind::state, "event " + std::to_string(i), {}});
    ASSERT_FALSE(j.flush({}));
  }
  EXPECT_EQ(lines(j.path()), 500U);
}

TEST_F(TimelineJournalTest, AMissingFileIsNoHistory) {
  std::map<std::string, std::vector<TimelineEvent>> back{{"stale", {}}};
  EXPECT_FALSE(TimelineJournal(dir_, "line1").load(back));
  EXPECT_TRUE(back.empty());
}

}  // namespace
}  // namespace cobridge::gateway
