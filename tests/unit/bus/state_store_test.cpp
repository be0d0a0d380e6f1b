// StateStore: the assignments file that lets a restart skip the scan
// ("Assignments are kept in a state file, so a restart needs no new
// scan"; "A configuration fingerprint lets an unchanged device come up
// without being rewritten").
#include "bus/state_store.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>

namespace cobridge::gateway {
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
  std::string read_file() const {
    std::ifstream in(dir_ / StateStore::kFileName, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
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

TEST_F(StateStoreTest, MalformedLinesAreReportedWithFileLineAndSkipped) {
  write_file(
      "# comment\n"
      "\n"
      "bus=line1 serial=0x3E9 vendor=0x182 product=0xBE0 revision=0x1 node=5 fingerprint=abc\n"  // 3: good
      "this is garbage\n"                                                                        // 4
      "bus=line1 serial=12 vendor=0x182 product=0xBE0 revision=1 node=200\n"                    // 5: node > 127
      "bus=line1 serial=zz vendor=1 product=1 revision=1 node=1\n"                              // 6: number
      "bus=line1 vendor=1 product=1 revision=1 node=1\n"                                        // 7: no serial
      "\x01\x02\xff\xfe=\n"                                                                     // 8: binary
      "bus=line1 serial=0x3EA vendor=0x182 product=0xBE0 revision=0x1 node=6 future=1\r\n");    // 9: good
  StateStore store(dir_);
  const cobridge::Error e = store.load();
  EXPECT_EQ(e.kind, cobridge::Errc::kInvalidArgument);
  EXPECT_EQ(e.code, make_error_code(StateStoreErrc::malformed_lines));
  const std::string file = (dir_ / "assignments.state").string();
  EXPECT_EQ(e.where, file);
  const std::string& message = e.message;
  for (int line : {4, 5, 6, 7, 8}) {
    EXPECT_NE(message.find(file + ":" + std::to_string(line) + ":"), std::string::npos) << "line " << line << "\n"
                                                                                          << message;
  }
  EXPECT_EQ(message.find(file + ":3:"), std::string::npos);
  EXPECT_EQ(message.find(file + ":9:"), std::string::npos);
  EXPECT_EQ(store.on_bus("line1").size(), 2U);
  EXPECT_EQ(store.find("line1", 0x182, 0xBE0, 1001)->fingerprint, "abc");
  EXPECT_EQ(store.find("line1", 0x182, 0xBE0, 1002)->node_id, 6);
}

TEST_F(StateStoreTest, RandomGarbageNeverCrashes) {
  std::mt19937 rng(42);
  for (int round = 0; round < 50; ++round) {
    std::string text;
    const auto n = rng() % 400;
    for (unsigned i = 0; i < n; ++i) text += static_cast<char>(rng() % 256);
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

}  // namespace
}  // namespace cobridge::gateway
