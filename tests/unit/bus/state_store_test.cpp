// StateStore: the assignments file that lets a restart skip the scan
// ("Assignments are kept in a state file, so a restart needs no new
// scan"; "A configuration fingerprint lets an unchanged device come up
// without being rewritten"); a file it cannot read is kept and holds every
// assignment until an operator decides.
#include "bus/state_store.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <future>
#include <mutex>
#include <random>
#include <sstream>
#include <thread>

namespace cobridge::bus {
namespace {

namespace fs = std::filesystem;

class StateStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device rd;
    dir_ = fs::temp_directory_path() /
           ("cobridge-state-test-" + std::to_string(::getpid()) + "-" + std::to_string(rd()));
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  void write_file(const std::string& text) {
    fs::create_directories(dir_);
    std::ofstream(dir_ / StateStore::kFileName, std::ios::binary) << text;
  }
  std::string read_file() const { return read(dir_ / StateStore::kFileName); }
  static std::string read(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  }
  // assignments.state.bad-*: the files the store set aside.
  std::vector<fs::path> aside_copies() const {
    std::vector<fs::path> out;
    for (const auto& e : fs::directory_iterator(dir_))
      if (e.path().filename().string().rfind("assignments.state.bad-", 0) == 0) out.push_back(e.path());
    return out;
  }

  fs::path dir_;
};

Assignment sample(std::uint32_t serial, std::uint8_t node, std::string bus = "line1") {
  Assignment a;
  a.bus = std::move(bus);
  a.serial = serial;
  a.vendor = 0x182;       // Novotechnik (J§1.2.1)
  a.product = 0x0BE0;     // RFC-4800 (J§1.2.1)
  a.revision = 0x10002;
  a.node_id = node;
  a.fingerprint = "a1b2c3d4e5f60718";
  return a;
}

TEST_F(StateStoreTest, MissingFileIsAnEmptyStore) {
  StateStore store(dir_);
  const cobridge::Error e = store.load();
  EXPECT_FALSE(e) << e.to_string();
  EXPECT_TRUE(store.on_bus("line1").empty());
  EXPECT_FALSE(store.find("line1", 0x182, 0x0BE0, 1).has_value());
}

TEST_F(StateStoreTest, RoundTripThroughTheFile) {
  {
    StateStore store(dir_);
    ASSERT_FALSE(store.put(sample(1001, 5)));
    ASSERT_FALSE(store.put(sample(1002, 6)));
    Assignment odd = sample(7, 9, "bus with spaces=%#");
    odd.fingerprint.clear();  // never configured
    odd.vendor = 0x0069666D;  // ifm (F§7.3 0x1018)
    ASSERT_FALSE(store.put(odd));
  }
  EXPECT_TRUE(fs::exists(dir_ / "assignments.state"));
  StateStore again(dir_);
  ASSERT_FALSE(again.load());
  const auto a = again.find("line1", 0x182, 0x0BE0, 1001);
  ASSERT_TRUE(a.has_value());
  EXPECT_EQ(*a, sample(1001, 5));
  EXPECT_EQ(again.on_bus("line1").size(), 2U);
  const auto odd = again.find("bus with spaces=%#", 0x0069666D, 0x0BE0, 7);
  ASSERT_TRUE(odd.has_value());
  EXPECT_EQ(odd->node_id, 9);
  EXPECT_TRUE(odd->fingerprint.empty());
  // Nothing left behind from the atomic write.
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_)) ++files;
  EXPECT_EQ(files, 1U);
}

TEST_F(StateStoreTest, PutReplacesTheSameDeviceAndEraseRemovesIt) {
  StateStore store(dir_);
  ASSERT_FALSE(store.put(sample(1001, 5)));
  auto changed = sample(1001, 12);
  changed.fingerprint = "ffff";
  ASSERT_FALSE(store.put(changed));
  ASSERT_EQ(store.on_bus("line1").size(), 1U);
  EXPECT_EQ(store.find("line1", 0x182, 0x0BE0, 1001)->node_id, 12);
  // Same serial on another bus or another product is another device.
  ASSERT_FALSE(store.put(sample(1001, 5, "line2")));
  EXPECT_EQ(store.on_bus("line2").size(), 1U);
  ASSERT_FALSE(store.erase("line1", 0x182, 0x0BE0, 1001));
  EXPECT_FALSE(store.find("line1", 0x182, 0x0BE0, 1001).has_value());
  StateStore again(dir_);
  ASSERT_FALSE(again.load());
  EXPECT_TRUE(again.on_bus("line1").empty());
  EXPECT_EQ(again.on_bus("line2").size(), 1U);
}

// A line that does not read makes the whole file
// untrusted: it is set aside (never written over), every problem named as
// file:line (the first five, then a count), and the store holds.
TEST_F(StateStoreTest, ALineThatDoesNotReadSetsTheFileAsideAndHolds) {
  const std::string text =
      "# comment\n"
      "\n"
      "bus=line1 serial=0x3E9 vendor=0x182 product=0xBE0 revision=0x1 node=5 fingerprint=abc\n"  // 3: good
      "this is garbage\n"                                                                        // 4
      "bus=line1 serial=12 vendor=0x182 product=0xBE0 revision=1 node=200\n"                    // 5: node > 127
      "bus=line1 serial=zz vendor=1 product=1 revision=1 node=1\n"                              // 6: number
      "bus=line1 vendor=1 product=1 revision=1 node=1\n"                                        // 7: no serial
      "\x01\x02\xff\xfe=\n"                                                                     // 8: binary
      "bus=line1 serial=0x3EA vendor=0x182 product=0xBE0 revision=0x1 node=6 future=1\r\n"      // 9: good
      "x\ny\nz\n";                                                                              // 10-12
  write_file(text);
  StateStore store(dir_);
  const cobridge::Error e = store.load();
  EXPECT_EQ(e.kind, cobridge::Errc::kInvalidArgument);
  EXPECT_EQ(e.code, make_error_code(StateStoreErrc::malformed_lines));
  const std::string file = (dir_ / "assignments.state").string();
  EXPECT_EQ(e.where, file);
  const std::string& message = e.message;
  EXPECT_EQ(message.rfind("8 lines do not read:\n", 0), 0u) << message;
  for (int line : {4, 5, 6, 7, 8}) {
    EXPECT_NE(message.find(file + ":" + std::to_string(line) + ":"), std::string::npos) << "line " << line << "\n"
                                                                                          << message;
  }
  EXPECT_EQ(message.find(file + ":3:"), std::string::npos);
  EXPECT_EQ(message.find(file + ":10:"), std::string::npos);
  EXPECT_NE(message.find("\n3 more\n"), std::string::npos) << message;
  EXPECT_EQ(message.find('\xff'), std::string::npos) << "the file's bytes reach the log";
  // Nothing of it is trusted; its bytes are kept under another name.
  EXPECT_TRUE(store.on_bus("line1").empty());
  EXPECT_FALSE(fs::exists(dir_ / "assignments.state"));
  const auto aside = aside_copies();
  ASSERT_EQ(aside.size(), 1u);
  EXPECT_EQ(read(aside[0]), text);
  EXPECT_NE(message.find("set aside as " + aside[0].string()), std::string::npos) << message;
  const std::string hold = store.hold();
  EXPECT_NE(hold.find("could not be read (8 lines do not read)"), std::string::npos) << hold;
  EXPECT_NE(hold.find(aside[0].string()), std::string::npos) << hold;
  EXPECT_NE(hold.find("no node-ID is assigned until an operator decides"), std::string::npos) << hold;
}

// 2 KiB of binary garbage in place of the
// state file. Its bytes stay on the disk (set aside), and while the store
// holds no assignment writes the file: the set-aside copy is never replaced
// and the state file's place stays empty for the operator's decision.
TEST_F(StateStoreTest, BinaryGarbageIsKeptAndNeverOverwritten) {
  std::mt19937 rng(38);
  std::string garbage;
  for (int i = 0; i < 2048; ++i) garbage += static_cast<char>(rng() % 256);
  write_file(garbage);
  StateStore store(dir_);
  const cobridge::Error e = store.load();
  ASSERT_TRUE(e);
  EXPECT_FALSE(store.hold().empty());
  EXPECT_LT(e.message.size(), 2000u) << "the log line holds the garbage";
  // What a commissioning or a configuration would record.
  EXPECT_FALSE(store.put(sample(1001, 5)));
  EXPECT_EQ(store.find("line1", 0x182, 0x0BE0, 1001)->node_id, 5);  // in memory
  EXPECT_FALSE(store.erase("line1", 0x182, 0x0BE0, 1001));
  EXPECT_FALSE(store.put(sample(1002, 6)));
  EXPECT_FALSE(fs::exists(dir_ / "assignments.state"));
  const auto aside = aside_copies();
  ASSERT_EQ(aside.size(), 1u);
  EXPECT_EQ(read(aside[0]), garbage);
}

// The hold outlives a restart. With no state file and a
// set-aside copy beside it the store holds again (a missing file is not a
// fresh start then); a file that reads, the operator's decision (an empty
// one: start without the memory), releases it, and the file is written again.
TEST_F(StateStoreTest, TheHoldOutlivesARestartUntilAFileThatReadsIsPutBack) {
  write_file("garbage\n");
  {
    StateStore store(dir_);
    ASSERT_TRUE(store.load());
  }
  StateStore again(dir_);
  const cobridge::Error e = again.load();
  EXPECT_EQ(e.code, make_error_code(StateStoreErrc::held));
  EXPECT_NE(again.hold().find(aside_copies().at(0).string()), std::string::npos) << again.hold();
  EXPECT_FALSE(again.put(sample(1001, 5)));
  EXPECT_FALSE(fs::exists(dir_ / "assignments.state"));
  write_file("");  // the operator: start without the memory
  const cobridge::Error released = again.load();
  EXPECT_FALSE(released) << released.to_string();
  EXPECT_TRUE(again.hold().empty());
  EXPECT_TRUE(again.on_bus("line1").empty());  // what the memory had while it held is gone with it
  ASSERT_FALSE(again.put(sample(1001, 5)));
  EXPECT_NE(read_file().find("serial=0x3E9"), std::string::npos);
  EXPECT_EQ(aside_copies().size(), 1u);  // the copy is the operator's to remove
}

// Unreadable is not only bad syntax: a symbolic link (the
// file it names is never read nor written) and a file larger than any state
// file are set aside too.
TEST_F(StateStoreTest, ASymbolicLinkOrAnOversizedFileIsSetAside) {
  fs::create_directories(dir_);
  std::ofstream(dir_ / "elsewhere") << "bus=line1 serial=1 vendor=1 product=1 revision=1 node=5\n";
  fs::create_symlink(dir_ / "elsewhere", dir_ / StateStore::kFileName);
  StateStore store(dir_);
  const cobridge::Error e = store.load();
  EXPECT_EQ(e.code, make_error_code(StateStoreErrc::read_failed));
  EXPECT_NE(e.message.find("symbolic link"), std::string::npos) << e.message;
  EXPECT_TRUE(store.on_bus("line1").empty());
  ASSERT_EQ(aside_copies().size(), 1u);
  EXPECT_TRUE(fs::is_symlink(aside_copies()[0]));
  EXPECT_FALSE(store.put(sample(1001, 5)));
  EXPECT_EQ(read(dir_ / "elsewhere"), "bus=line1 serial=1 vendor=1 product=1 revision=1 node=5\n");

  fs::remove(aside_copies()[0]);
  write_file(std::string(StateStore::kMaxFileBytes + 1, '#'));
  const cobridge::Error big = store.load();
  EXPECT_EQ(big.code, make_error_code(StateStoreErrc::read_failed));
  EXPECT_NE(big.message.find(std::to_string(StateStore::kMaxFileBytes + 1) + " bytes"), std::string::npos)
      << big.message;
  EXPECT_EQ(aside_copies().size(), 1u);
}

TEST_F(StateStoreTest, RandomGarbageNeverCrashes) {
  std::mt19937 rng(42);
  for (int round = 0; round < 50; ++round) {
    std::string text;
    const auto n = rng() % 400;
    for (unsigned i = 0; i < n; ++i) text += static_cast<char>(rng() % 256);
    fs::remove_all(dir_);  // no set-aside copy from the round before
    write_file(text);
    StateStore store(dir_);
    (void)store.load();
    // Whatever was loaded can be written back.
    for (const auto& a : store.on_bus("line1")) EXPECT_FALSE(store.put(a));
  }
}

TEST_F(StateStoreTest, ConcurrentPutsFromTwoThreadsKeepEveryEntry) {
  StateStore store(dir_);
  auto writer = [&store](std::string bus) {
    for (std::uint32_t serial = 1; serial <= 40; ++serial) {
      ASSERT_FALSE(store.put(sample(serial, static_cast<std::uint8_t>(serial), bus)));
    }
  };
  std::thread a(writer, "line1");
  std::thread b(writer, "line2");
  a.join();
  b.join();
  EXPECT_EQ(store.on_bus("line1").size(), 40U);
  EXPECT_EQ(store.on_bus("line2").size(), 40U);
  StateStore again(dir_);
  ASSERT_FALSE(again.load());
  EXPECT_EQ(again.on_bus("line1").size(), 40U);
  EXPECT_EQ(again.on_bus("line2").size(), 40U);
}

TEST_F(StateStoreTest, InvalidAssignmentsAreRefused) {
  StateStore store(dir_);
  EXPECT_EQ(store.put(sample(1, 128)).code, make_error_code(StateStoreErrc::invalid_assignment));
  EXPECT_EQ(store.put(sample(1, 5, "")).code, make_error_code(StateStoreErrc::invalid_assignment));
  EXPECT_FALSE(fs::exists(dir_ / "assignments.state"));
}

TEST_F(StateStoreTest, UnwritableDirectoryIsAnErrorNotACrash) {
  fs::create_directories(dir_);
  std::ofstream(dir_ / "blocker") << "x";
  StateStore store(dir_ / "blocker");  // a file where the directory should be
  EXPECT_TRUE(store.put(sample(1, 5)));
  EXPECT_TRUE(store.on_bus("line1").empty());
}

// The bus control thread sends the heartbeat of a hot-standby
// pair's master; it stopped for the two fsyncs of a state file write (over
// 150 ms on a busy disk, longer than the standby waits for the master's
// heartbeat). With the writer thread, put() returns while the disk is still
// busy, every reader sees the new table at once, and the file gets the
// latest table.
class GatedDisk {
 public:
  // The FileWriter: waits until open() (or the first call fails when told to).
  StateStore::FileWriter writer() {
    return [this](const fs::path& path, const std::string& text) -> cobridge::Error {
      std::unique_lock lock(mutex_);
      ++calls_;
      changed_.notify_all();
      changed_.wait(lock, [this] { return open_; });
      if (fail_first_ && calls_ == 1) return cobridge::Error(cobridge::Errc::kFailed, "disk full", path.string());
      std::ofstream(path, std::ios::binary) << (garble_ ? std::string("\x01\xFF" "torn") : text);
      return {};
    };
  }
  void open() {
    const std::lock_guard lock(mutex_);
    open_ = true;
    changed_.notify_all();
  }
  void fail_first() { fail_first_ = true; }
  // Every write leaves bytes that do not read (a bad disk).
  void garble() { garble_ = true; }
  bool wait_calls(int n) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, std::chrono::seconds(5), [&] { return calls_ >= n; });
  }
  int calls() {
    const std::lock_guard lock(mutex_);
    return calls_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  bool open_ = false;
  bool fail_first_ = false;
  bool garble_ = false;
  int calls_ = 0;
};

TEST_F(StateStoreTest, WithTheWriterThreadPutNeverWaitsForTheDisk) {
  fs::create_directories(dir_);
  GatedDisk disk;
  StateStore store(dir_, disk.writer());
  store.start_writer();
  // A bus thread's puts while the disk is busy with the first write.
  auto bus_thread = std::async(std::launch::async, [&store] {
    for (std::uint32_t serial = 1; serial <= 20; ++serial) {
      if (store.put(sample(serial, static_cast<std::uint8_t>(serial)))) return false;
    }
    return true;
  });
  ASSERT_TRUE(disk.wait_calls(1));  // a write is in the disk now, and stays there
  const bool returned = bus_thread.wait_for(std::chrono::seconds(1)) == std::future_status::ready;
  // (A put() still in the disk holds the table: not asked then.)
  const std::size_t seen = returned ? store.on_bus("line1").size() : 0;
  disk.open();
  EXPECT_TRUE(bus_thread.get());
  EXPECT_TRUE(returned) << "put() waited for the disk";
  EXPECT_EQ(seen, 20U) << "readers see the table at once";
  store.stop_writer();
  EXPECT_LE(disk.calls(), 3) << "the changes made while the disk was busy are one write";
  StateStore again(dir_);
  ASSERT_FALSE(again.load());
  EXPECT_EQ(again.on_bus("line1").size(), 20U);
}

TEST_F(StateStoreTest, AFailedBackgroundWriteIsTriedAgain) {
  fs::create_directories(dir_);
  GatedDisk disk;
  disk.fail_first();
  disk.open();
  StateStore store(dir_, disk.writer());
  store.start_writer();
  EXPECT_FALSE(store.put(sample(7, 9)));  // the failure is the writer thread's to log
  ASSERT_TRUE(disk.wait_calls(1));
  store.stop_writer();  // tries once more at once rather than a second later
  EXPECT_EQ(disk.calls(), 2);
  EXPECT_NE(read_file().find("node=9"), std::string::npos);
}

TEST_F(StateStoreTest, TheDestructorWritesWhatIsPending) {
  {
    StateStore store(dir_);
    store.start_writer();
    ASSERT_FALSE(store.put(sample(3, 12)));
  }
  StateStore again(dir_);
  ASSERT_FALSE(again.load());
  ASSERT_EQ(again.on_bus("line1").size(), 1U);
  EXPECT_EQ(again.on_bus("line1")[0].node_id, 12);
}

// The writer thread and the hold. A reload
// (load()) waits for the write in the disk, so it reads what that write left;
// when that cannot be read the file is set aside, and from then on nothing is
// written (a put made meanwhile is dropped), so the state file's place stays
// empty for the operator. Without the wait the reload would read no file and
// start fresh, and the writes would go on.
TEST_F(StateStoreTest, AReloadWaitsForTheWriteInTheDiskAndAHoldStopsTheWriter) {
  fs::create_directories(dir_);
  GatedDisk disk;
  disk.garble();
  StateStore store(dir_, disk.writer());
  ASSERT_FALSE(store.load());
  store.start_writer();
  ASSERT_FALSE(store.put(sample(1, 5)));
  ASSERT_TRUE(disk.wait_calls(1));        // the first write is in the disk
  ASSERT_FALSE(store.put(sample(2, 6)));  // pending behind it
  auto reload = std::async(std::launch::async, [&store] { return store.load(); });
  EXPECT_EQ(reload.wait_for(std::chrono::milliseconds(200)), std::future_status::timeout)
      << "load() read the file while a write was in the disk";
  disk.open();
  const cobridge::Error e = reload.get();
  EXPECT_EQ(e.code, make_error_code(StateStoreErrc::malformed_lines)) << e.to_string();
  EXPECT_FALSE(store.hold().empty());
  const int calls = disk.calls();
  ASSERT_FALSE(store.put(sample(3, 7)));
  store.stop_writer();
  EXPECT_EQ(disk.calls(), calls) << "a write was made while the store held";
  EXPECT_FALSE(fs::exists(dir_ / StateStore::kFileName));
  ASSERT_EQ(aside_copies().size(), 1u);
  EXPECT_EQ(read(aside_copies()[0]), "\x01\xFF" "torn");
}

}  // namespace
}  // namespace cobridge::bus
