// The timeline journal's writer thread: the bus's control thread never
// waits for the disk, and nothing noted is lost at the stop.
#include "bus/timeline_journal_thread.hpp"

#include <gtest/gtest.h>

#include "unit/support/temp_dir.hpp"

#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

namespace cobridge::bus {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
const std::chrono::system_clock::time_point kT0{std::chrono::milliseconds(1'800'000'000'123)};

class TimelineJournalThreadTest : public ::testing::Test {
 protected:
  test::TempDir tmp_{"journal-thread-test"};
  const fs::path& dir_ = tmp_.path();
};

TEST_F(TimelineJournalThreadTest, WritesWhatIsHandedOverAndTheRestAtItsEnd) {
  DeviceTimeline tl;
  {
    TimelineJournalThread writer(TimelineJournal(dir_, "line1"), "line1");
    tl.add({kT0, TimelineKind::boot_up, "boot-up", {}});
    writer.note("lift", tl.events().back());
    EXPECT_TRUE(writer.pending());
    writer.hand_over({{"lift", tl}});
    EXPECT_FALSE(writer.pending());
    tl.add({kT0 + 1s, TimelineKind::state, "identified -> configuring", {}});
    writer.note("lift", tl.events().back());  // noted after the last hand-over
  }
  std::map<std::string, std::vector<TimelineEvent>> back;
  ASSERT_FALSE(TimelineJournal(dir_, "line1").load(back));
  ASSERT_EQ(back["lift"].size(), 2U);
  EXPECT_EQ(back["lift"][1].text, "identified -> configuring");
}

TEST_F(TimelineJournalThreadTest, AFailingDiskIsNoCrashAndTheEventsWaitForTheNextHandOver) {
  fs::create_directories(dir_);
  std::ofstream(dir_ / "timelines") << "x";  // a file where the directory should be
  DeviceTimeline tl;
  {
    TimelineJournalThread writer(TimelineJournal(dir_, "line1"), "line1");
    tl.add({kT0, TimelineKind::boot_up, "boot-up", {}});
    writer.note("lift", tl.events().back());
    writer.hand_over({{"lift", tl}});
    std::this_thread::sleep_for(50ms);  // the failed write (logged)
    fs::remove(dir_ / "timelines");
    tl.add({kT0 + 1s, TimelineKind::state, "identified -> configuring", {}});
    writer.note("lift", tl.events().back());
    writer.hand_over({{"lift", tl}});
  }
  std::map<std::string, std::vector<TimelineEvent>> back;
  ASSERT_FALSE(TimelineJournal(dir_, "line1").load(back));
  ASSERT_EQ(back["lift"].size(), 2U);  // the first one kept for the second try
  EXPECT_EQ(back["lift"][0].text, "boot-up");
}

}  // namespace
}  // namespace cobridge::bus
