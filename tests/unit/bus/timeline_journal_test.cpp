// The timeline journal (docs/operations.md "Why a device is where it is:
// the timeline": the timeline outlives a restart of the daemon): events
// read back as they were written, a storm costs one line per flush, the
// file stays bounded, and a damaged line is named and skipped.
#include "bus/timeline_journal.hpp"

#include <gtest/gtest.h>

#include "unit/support/temp_dir.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>

namespace cobridge::bus {
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

// A symbolic link planted as the journal (to a file the
// daemon must not read or write) is refused with an error naming it, and
// never followed: nothing is read from the file it names, nothing appended.
TEST_F(TimelineJournalTest, ASymbolicLinkAsTheJournalIsRefusedNeverFollowed) {
  fs::create_directories(dir_ / "timelines");
  const std::string victim_text =
      TimelineJournal::format_line("lift", {kT0, TimelineKind::boot_up, "from the victim", {}}) + "\n";
  std::ofstream(dir_ / "victim") << victim_text;
  fs::create_symlink(dir_ / "victim", dir_ / "timelines" / "line1.timeline");
  TimelineJournal j(dir_, "line1");
  std::map<std::string, std::vector<TimelineEvent>> back;
  const Error e = j.load(back);
  ASSERT_TRUE(e);
  EXPECT_EQ(e.where, j.path().string());
  EXPECT_NE(e.message.find("symbolic link"), std::string::npos) << e.message;
  EXPECT_TRUE(back.empty());
  DeviceTimeline tl;
  add(j, "lift", tl, {kT0 + 1s, TimelineKind::state, "appended?", {}});
  const Error w = j.flush({});  // no timelines: an append, not a compaction
  ASSERT_TRUE(w);
  EXPECT_NE(w.message.find("symbolic link"), std::string::npos) << w.message;
  std::ifstream in(dir_ / "victim");
  std::ostringstream text;
  text << in.rdbuf();
  EXPECT_EQ(text.str(), victim_text);
}

// Reads are bounded. A line over kMaxLineBytes is skipped
// and named with its size, not its content; of a file over kMaxLoadBytes
// (16 MB logged a 9.3 MB warning line before) only the newest part is read,
// the warning names the file and its size, and the next write rewrites the
// file from memory.
TEST_F(TimelineJournalTest, AnOverlongLineAndAnOversizedFileAreReadWithinBounds) {
  fs::create_directories(dir_ / "timelines");
  const fs::path file = dir_ / "timelines" / "line1.timeline";
  const std::string event = TimelineJournal::format_line("lift", {kT0, TimelineKind::boot_up, "boot-up", {}});
  {
    std::ofstream out(file, std::ios::binary);
    out << "at=1 device=lift kind=state text=" << std::string(TimelineJournal::kMaxLineBytes, 'A') << "\n";
    out << event << "\n";
  }
  std::map<std::string, std::vector<TimelineEvent>> back;
  const Error e = TimelineJournal(dir_, "line1").load(back);
  ASSERT_TRUE(e);
  EXPECT_NE(e.message.find(file.string() + ":1: " + std::to_string(TimelineJournal::kMaxLineBytes + 33) +
                           " bytes, longer than the 4096 a line may have"),
            std::string::npos)
      << e.message;
  EXPECT_EQ(e.message.find("AAAA"), std::string::npos) << "the line's content is in the warning";
  EXPECT_EQ(back["lift"].size(), 1U);

  {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    const std::string filler = "# " + std::string(1000, 'B') + "\n";
    for (std::uint64_t n = 0; n <= TimelineJournal::kMaxLoadBytes / filler.size(); ++n) out << filler;
    out << event << "\n";
  }
  const auto size = fs::file_size(file);
  TimelineJournal big(dir_, "line1");
  const Error b = big.load(back);
  ASSERT_TRUE(b);
  EXPECT_LT(b.message.size(), 1000U);
  EXPECT_NE(b.message.find(file.string() + ": " + std::to_string(size) + " bytes, more than the " +
                           std::to_string(TimelineJournal::kMaxLoadBytes) + " read"),
            std::string::npos)
      << b.message;
  ASSERT_EQ(back["lift"].size(), 1U);  // the newest part was read
  DeviceTimeline tl(back["lift"]);
  add(big, "lift", tl, {kT0 + 1s, TimelineKind::state, "after", {}});
  ASSERT_FALSE(big.flush({{"lift", tl}}));
  EXPECT_LT(fs::file_size(file), 1000U);  // rewritten from memory
}

// An `at=` (or `last=`) after the year 2262 does not fit
// the clock's 64-bit nanoseconds: the line is refused, without undefined
// behaviour (UBSan reported the overflow before); the clock's last
// millisecond still reads.
TEST_F(TimelineJournalTest, ATimeBeyondTheClockIsRefusedWithoutOverflow) {
  const std::uint64_t last_ms = static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::duration::max()).count());
  for (const std::string& at : {std::to_string(last_ms + 1), std::string("18446744073709551615")}) {
    auto r = TimelineJournal::parse_line("at=" + at + " device=lift kind=state text=x");
    ASSERT_FALSE(r.ok()) << at;
    EXPECT_EQ(r.error().kind, Errc::kInvalidArgument);
    EXPECT_EQ(r.error().message, "'at' is after the year 2262, the clock's end");
    r = TimelineJournal::parse_line("at=1 last=" + at + " device=lift kind=state text=x");
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().message, "'last' is after the year 2262, the clock's end");
  }
  const auto r = TimelineJournal::parse_line("at=" + std::to_string(last_ms) + " device=lift kind=state text=x");
  ASSERT_TRUE(r.ok()) << r.error().to_string();
  EXPECT_EQ(r->device, "lift");
  EXPECT_EQ(std::chrono::duration_cast<std::chrono::milliseconds>(r->event.at.time_since_epoch()).count(),
            static_cast<std::int64_t>(last_ms));
}

TEST_F(TimelineJournalTest, AMissingFileIsNoHistory) {
  std::map<std::string, std::vector<TimelineEvent>> back{{"stale", {}}};
  EXPECT_FALSE(TimelineJournal(dir_, "line1").load(back));
  EXPECT_TRUE(back.empty());
}

}  // namespace
}  // namespace cobridge::bus
