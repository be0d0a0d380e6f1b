// CaptureWriter: the flight recorder's capture files (docs/operations.md,
// "Flight recorder"). The line format is can-utils' candump -l log format,
// the one canplayer reads: "(SEC.USEC) IFACE ID#DATA", 3 hex digits for an
// 11-bit identifier, 8 for a 29-bit one (and error frames, CAN_ERR_FLAG
// set), "#R" for a remote frame (can-utils lib.c, parse_canframe/sprint_canframe).
#include "bus/capture_writer.hpp"

#include <gtest/gtest.h>
#include <spdlog/sinks/ringbuffer_sink.h>

#include "sys/logging.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

namespace cobridge::bus {
namespace {

namespace fs = std::filesystem;
constexpr std::int64_t kSecond = 1'000'000'000;
constexpr std::int64_t kT0 = 1'764'300'000LL * kSecond;  // 2025-11-28, a whole second

can::Frame frame_at(std::int64_t ns, std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  can::Frame f = can::Frame::make(id, bytes);
  f.timestamp_ns = ns;
  return f;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The "gateway" logger's lines while it lives.
class GatewayLog {
 public:
  GatewayLog() { sys::logger("gateway")->sinks().push_back(sink_); }
  ~GatewayLog() { std::erase(sys::logger("gateway")->sinks(), sink_); }
  GatewayLog(const GatewayLog&) = delete;
  GatewayLog& operator=(const GatewayLog&) = delete;
  [[nodiscard]] std::size_t count(const std::string& text) const {
    const auto lines = sink_->last_formatted();
    return static_cast<std::size_t>(
        std::count_if(lines.begin(), lines.end(), [&](const std::string& l) { return l.find(text) != std::string::npos; }));
  }

 private:
  std::shared_ptr<spdlog::sinks::ringbuffer_sink_mt> sink_ = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(64);
};

class CaptureWriterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("cobridge-captures-" + std::to_string(::getpid()) + "-" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  CaptureOptions options() const {
    CaptureOptions o;
    o.dir = dir_;
    o.bus = "line1";
    o.interface = "vcan0";
    o.before = std::chrono::seconds(10);
    o.after = std::chrono::seconds(2);
    return o;
  }
  fs::path dir_;
};

TEST(CandumpLine, StandardExtendedRtrAndErrorFrames) {
  EXPECT_EQ(candump_line(frame_at(kT0 + 123'456'789, 0x701, {0x00}), "vcan0"), "(1764300000.123456) vcan0 701#00\n");
  can::Frame ext = frame_at(5 * kSecond + 1000, 0x1ABCDEF, {0xDE, 0xAD});
  ext.flags = can::Frame::kFlagExtended;
  EXPECT_EQ(candump_line(ext, "can1"), "(5.000001) can1 01ABCDEF#DEAD\n");
  can::Frame rtr = frame_at(0, 0x70A, {});
  rtr.flags = can::Frame::kFlagRtr;
  EXPECT_EQ(candump_line(rtr, "vcan0"), "(0.000000) vcan0 70A#R\n");
  EXPECT_EQ(candump_line(frame_at(0, 0x80, {}), "vcan0"), "(0.000000) vcan0 080#\n");
  can::Frame err = frame_at(0, 0x004, {0, 0x04, 0, 0, 0, 0, 0, 0});
  err.flags = can::Frame::kFlagError;
  EXPECT_EQ(candump_line(err, "vcan0"), "(0.000000) vcan0 20000004#0004000000000000\n");
}

// A capture of an earlier run: its time and cause from its name, as the writer names it.
TEST(CaptureFromName, TheNameGivesTheFaultTimeAndCause) {
  const CaptureInfo c = capture_from_name("line1-20261128T015512.345Z-heartbeat-lost.log", 6);
  EXPECT_EQ(c.fault_ns, 1795830912345000000LL);  // date -u -d 2026-11-28T01:55:12 +%s = 1795830912
  EXPECT_EQ(c.causes, (std::vector<std::string>{"heartbeat lost"}));
  const CaptureInfo odd = capture_from_name("line1-garbage.log", 6);
  EXPECT_EQ(odd.name, "line1-garbage.log");
  EXPECT_EQ(odd.fault_ns, 0);
  EXPECT_TRUE(odd.causes.empty());
}

// A name's year 9999 (or 0000) is beyond the 64-bit
// nanoseconds since 1970 (1677..2262): the name alone, without overflow.
TEST(CaptureFromName, AYearBeyondTheClockGivesTheNameOnlyWithoutOverflow) {
  for (const char* name : {"line1-99991231T235959.999Z-emcy.log", "line1-00000101T000000.000Z-emcy.log"}) {
    const CaptureInfo c = capture_from_name(name, 6);
    EXPECT_EQ(c.name, name);
    EXPECT_EQ(c.fault_ns, 0) << name;
  }
  EXPECT_NE(capture_from_name("line1-22611231T235959.999Z-emcy.log", 6).fault_ns, 0);
}

// Bus names are matched exactly. A capture of bus "a"
// is "a-<stamp>-<word>.log"; bus "a-1"'s "a-1-<stamp>-..." is not one of
// them, nor is anything but the stamp's digits after "<bus>-".
TEST(IsCaptureOf, BusNamesMatchExactly) {
  EXPECT_TRUE(is_capture_of("a-20261128T015512.345Z-boot-up.log", "a", ".log"));
  EXPECT_TRUE(is_capture_of("a-20261128T015512.345Z-boot-up.json", "a", ".json"));
  EXPECT_FALSE(is_capture_of("a-20261128T015512.345Z-boot-up.json", "a", ".log"));
  EXPECT_FALSE(is_capture_of("a-1-20261128T015512.345Z-boot-up.log", "a", ".log"));
  EXPECT_TRUE(is_capture_of("a-1-20261128T015512.345Z-boot-up.log", "a-1", ".log"));
  EXPECT_FALSE(is_capture_of("a-20261128T015512.345Z-boot-up.log", "a-1", ".log"));
  EXPECT_FALSE(is_capture_of("A-20261128T015512.345Z-boot-up.log", "a", ".log"));
  EXPECT_FALSE(is_capture_of("line_1-20261128T015512.345Z-emcy.log", "line-1", ".log"));
  // A bus whose name holds a stamp: its files are still not the shorter bus's.
  EXPECT_FALSE(is_capture_of("a-20261128T015512.345Z-20261128T015512.345Z-emcy.log", "a", ".log"));
  EXPECT_FALSE(is_capture_of("a-20261128T015512.345Z-.log", "a", ".log"));
  EXPECT_FALSE(is_capture_of("a-20261128T015512.345Z-x/y.log", "a", ".log"));
  EXPECT_FALSE(is_capture_of("a-2026112xT015512.345Z-emcy.log", "a", ".log"));
}

TEST(CaptureFileWord, LowercaseWordsJoinedByDashes) {
  EXPECT_EQ(capture_file_word("heartbeat lost"), "heartbeat-lost");
  EXPECT_EQ(capture_file_word("Boot-up"), "boot-up");
  EXPECT_EQ(capture_file_word("../x"), "x");
  EXPECT_EQ(capture_file_word(""), "fault");
}

TEST_F(CaptureWriterTest, WritesTheWindowAroundTheFaultOnceItCloses) {
  can::FrameRecorder rec(1000);
  for (int i = 0; i < 30; ++i) rec.record(frame_at(kT0 + std::int64_t{i} * kSecond, 0x181, {static_cast<std::uint8_t>(i)}));
  CaptureWriter w(options(), rec);
  w.request("boot-up", "enc1", kT0 + 15 * kSecond);
  EXPECT_TRUE(w.poll(kT0 + 16 * kSecond).empty());  // the window is still open
  const auto written = w.poll(kT0 + 17 * kSecond);
  ASSERT_EQ(written.size(), 1u);
  const CaptureInfo& c = written[0];
  // [15 s - 10 s, 15 s + 2 s]: frames 5..17.
  EXPECT_EQ(c.frames, 13u);
  EXPECT_EQ(c.name, "line1-20251128T032015.000Z-boot-up.log");
  const std::string log = slurp(dir_ / c.name);
  EXPECT_EQ(log.rfind("(1764300005.000000) vcan0 181#05\n", 0), 0u) << log;
  EXPECT_EQ(std::count(log.begin(), log.end(), '\n'), 13);
  EXPECT_EQ(c.bytes, log.size());
  const std::string side = slurp(dir_ / "line1-20251128T032015.000Z-boot-up.json");
  EXPECT_NE(side.find("\"causes\":[\"boot-up\"]"), std::string::npos) << side;
  EXPECT_NE(side.find("\"frames\":13"), std::string::npos) << side;
  EXPECT_FALSE(fs::exists(dir_ / (c.name + ".part")));
}

// Two CPUs can hand the socket two frames in the other order than their kernel stamps
// (a looped-back request beside an answer): the file is in stamp order, as canplayer replays.
TEST_F(CaptureWriterTest, TheFileIsInKernelStampOrder) {
  can::FrameRecorder rec(100);
  rec.record(frame_at(kT0 + 10 * kSecond, 0x714, {0x05}));
  rec.record(frame_at(kT0 + 10 * kSecond + 12'000, 0x7E5, {0x4C}));  // received first
  rec.record(frame_at(kT0 + 10 * kSecond + 5'000, 0x194, {0x00}));    // stamped earlier
  rec.record(frame_at(kT0 + 10 * kSecond + 12'000, 0x7E4, {0x50}));  // the same stamp: receive order kept
  CaptureWriter w(options(), rec);
  w.request("operator", "", kT0 + 10 * kSecond);
  const auto written = w.poll(kT0 + 13 * kSecond);
  ASSERT_EQ(written.size(), 1u);
  EXPECT_EQ(slurp(dir_ / written[0].name),
            "(1764300010.000000) vcan0 714#05\n(1764300010.000005) vcan0 194#00\n"
            "(1764300010.000012) vcan0 7E5#4C\n(1764300010.000012) vcan0 7E4#50\n");
}

// Frames the kernel dropped at the RX socket (Frame::dropped_before) are not in the
// file: the sidecar says where each gap is and how many frames it lost.
TEST_F(CaptureWriterTest, KernelDropsAreDeclaredAsGapsInTheSidecar) {
  can::FrameRecorder rec(1000);
  for (int i = 0; i < 30; ++i) {
    can::Frame f = frame_at(kT0 + std::int64_t{i} * kSecond, 0x181, {static_cast<std::uint8_t>(i)});
    if (i == 8) f.dropped_before = 3;
    if (i == 12) f.dropped_before = 70000 & 0xFFFF;
    if (i == 25) f.dropped_before = 9;  // outside the window
    rec.record(f);
  }
  GatewayLog log;
  CaptureWriter w(options(), rec);
  w.request("emcy", "enc1", kT0 + 15 * kSecond);
  const auto written = w.poll(kT0 + 17 * kSecond);
  ASSERT_EQ(written.size(), 1u);
  const CaptureInfo& c = written[0];
  // The window holds frames 5..17: frame 8 is line 4, frame 12 line 8.
  const std::vector<std::pair<std::size_t, std::uint32_t>> want{{4, 3}, {8, 70000 & 0xFFFF}};
  EXPECT_EQ(c.gaps, want);
  EXPECT_EQ(c.kernel_drops, 3u + (70000 & 0xFFFF));
  const std::string side = slurp(dir_ / "line1-20251128T032015.000Z-emcy.json");
  EXPECT_NE(side.find("\"kernel_drops\":4467,\"gaps\":[{\"line\":4,\"dropped\":3},{\"line\":8,\"dropped\":4464}]"),
            std::string::npos) << side;
  EXPECT_EQ(log.count("has 2 gaps: the kernel dropped 4467 frames"), 1u);
}

TEST_F(CaptureWriterTest, FaultsInsideAPendingWindowJoinIt) {
  can::FrameRecorder rec(100);
  rec.record(frame_at(kT0, 0x81, {0x10, 0x00}));
  CaptureWriter w(options(), rec);
  w.request("emcy", "enc1", kT0);
  w.request("emcy", "enc2", kT0 + kSecond);
  w.request("heartbeat lost", "enc1", kT0 + 2 * kSecond);
  w.request("emcy", "enc1", kT0 + 3 * kSecond);  // after the first window: a capture of its own
  EXPECT_EQ(w.pending(), 2u);
  const auto written = w.poll(kT0 + 10 * kSecond);
  ASSERT_EQ(written.size(), 2u);
  EXPECT_EQ(written[0].causes, (std::vector<std::string>{"emcy", "heartbeat lost"}));
  EXPECT_EQ(written[0].devices, (std::vector<std::string>{"enc1", "enc2"}));
  EXPECT_EQ(written[1].causes, (std::vector<std::string>{"emcy"}));
  EXPECT_EQ(w.recent().size(), 2u);
}

TEST_F(CaptureWriterTest, PendingCapturesAreBounded) {
  can::FrameRecorder rec(10);
  CaptureWriter w(options(), rec);
  for (int i = 0; i < 40; ++i) w.request("emcy", "enc1", kT0 + std::int64_t{i} * 10 * kSecond);
  EXPECT_EQ(w.pending(), 16u);
}

TEST_F(CaptureWriterTest, OldestCapturesGoFirstToKeepTheCap) {
  can::FrameRecorder rec(10000);
  // A frame each 40 ms: a 12 s window holds 300 lines of 47 bytes, ~14 kB.
  for (int i = 0; i < 1000; ++i) rec.record(frame_at(kT0 + std::int64_t{i} * 40'000'000, 0x181, {1, 2, 3, 4, 5, 6, 7, 8}));
  CaptureOptions o = options();
  o.cap_bytes = 30'000;  // room for two captures and their sidecars
  CaptureWriter w(o, rec);
  std::ofstream(dir_ / "line2-20251128T031800.000Z-emcy.log") << "another bus's capture stays\n";
  for (int i = 0; i < 4; ++i) {
    w.request("emcy", "enc1", kT0 + std::int64_t{20 + i * 3} * kSecond);
    (void)w.poll(kT0 + 40 * kSecond);
  }
  const auto left = w.recent();
  ASSERT_EQ(left.size(), 2u);
  EXPECT_EQ(left[0].name, "line1-20251128T032026.000Z-emcy.log");
  EXPECT_EQ(left[1].name, "line1-20251128T032029.000Z-emcy.log");
  std::uint64_t total = 0;
  for (const auto& e : fs::directory_iterator(dir_))
    if (e.path().filename().string().rfind("line1-", 0) == 0) total += e.file_size();
  EXPECT_LE(total, o.cap_bytes);
  EXPECT_TRUE(fs::exists(dir_ / "line2-20251128T031800.000Z-emcy.log"));
}

// Bus "a"'s cap and listing never take bus "a-1"'s
// captures (a prefix match counted, listed and deleted them).
TEST_F(CaptureWriterTest, ABusNeverListsNorDeletesTheCapturesOfABusWhoseNameExtendsIt) {
  can::FrameRecorder rec(10000);
  for (int i = 0; i < 1000; ++i) rec.record(frame_at(kT0 + std::int64_t{i} * 40'000'000, 0x181, {1, 2, 3, 4, 5, 6, 7, 8}));
  CaptureOptions o = options();
  o.bus = "a";
  o.cap_bytes = 30'000;
  const std::string other = "a-1-20251128T031800.000Z-emcy";
  std::ofstream(dir_ / (other + ".log")) << std::string(20'000, 'x');
  std::ofstream(dir_ / (other + ".json")) << "{}";
  CaptureWriter w(o, rec);
  for (int i = 0; i < 4; ++i) {
    w.request("emcy", "enc1", kT0 + std::int64_t{20 + i * 3} * kSecond);
    (void)w.poll(kT0 + 40 * kSecond);
  }
  const auto listed = w.recent();
  ASSERT_EQ(listed.size(), 2u);  // as many as its own cap holds: the other bus's bytes are not counted
  for (const auto& c : listed) EXPECT_EQ(c.name.rfind("a-2025", 0), 0u) << c.name;
  EXPECT_TRUE(fs::exists(dir_ / (other + ".log")));
  EXPECT_TRUE(fs::exists(dir_ / (other + ".json")));
  EXPECT_EQ(w.read(other + ".log").error().kind, Errc::kNotFound);
}

// A symbolic link planted in the captures folder under a
// capture's name is neither listed, nor served, nor counted or deleted by
// the cap: the file it names is never read or touched.
TEST_F(CaptureWriterTest, ASymbolicLinkInTheFolderIsNeverListedServedOrFollowed) {
  std::ofstream(dir_ / "secret") << "not a capture\n";
  fs::create_symlink(dir_ / "secret", dir_ / "line1-20251128T031800.000Z-emcy.log");
  can::FrameRecorder rec(10);
  rec.record(frame_at(kT0, 0x70A, {0x00}));
  CaptureOptions o = options();
  o.cap_bytes = 1;  // every capture on disk would go
  CaptureWriter w(o, rec);
  EXPECT_TRUE(w.recent().empty());
  EXPECT_EQ(w.read("line1-20251128T031800.000Z-emcy.log").error().kind, Errc::kNotFound);
  w.request("boot-up", "enc1", kT0);
  ASSERT_EQ(w.poll(kT0 + 5 * kSecond).size(), 1u);
  EXPECT_TRUE(fs::is_symlink(dir_ / "line1-20251128T031800.000Z-emcy.log"));
  EXPECT_EQ(slurp(dir_ / "secret"), "not a capture\n");
  const auto listed = w.recent();
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].name, "line1-20251128T032000.000Z-boot-up.log");
  const Result<std::string> text = w.read(listed[0].name);
  ASSERT_TRUE(text.ok()) << text.error().to_string();
  EXPECT_EQ(text.value(), "(1764300000.000000) vcan0 70A#00\n");
}

// A name planted where a capture goes (a link to a file
// the daemon must not write, at the partial file's or the log's name) is
// refused (O_EXCL; the rename never replaces): the capture is not written,
// the file the link names is untouched, and nothing half-written stays.
TEST_F(CaptureWriterTest, ANamePlantedWhereACaptureGoesIsNeverWrittenThrough) {
  std::ofstream(dir_ / "victim") << "precious\n";
  can::FrameRecorder rec(10);
  rec.record(frame_at(kT0, 0x70A, {0x00}));
  CaptureWriter w(options(), rec);
  const std::string name = w.request("boot-up", "enc1", kT0);
  ASSERT_EQ(name, "line1-20251128T032000.000Z-boot-up.log");
  fs::create_symlink(dir_ / "victim", dir_ / (name + ".part"));
  EXPECT_TRUE(w.poll(kT0 + 5 * kSecond).empty());
  EXPECT_EQ(slurp(dir_ / "victim"), "precious\n");
  EXPECT_FALSE(fs::exists(dir_ / "line1-20251128T032000.000Z-boot-up.json"));

  const std::string next = w.request("emcy", "enc1", kT0 + 10 * kSecond);
  fs::create_symlink(dir_ / "victim", dir_ / next);
  EXPECT_TRUE(w.poll(kT0 + 15 * kSecond).empty());
  EXPECT_EQ(slurp(dir_ / "victim"), "precious\n");
  EXPECT_TRUE(fs::is_symlink(dir_ / next));
  EXPECT_FALSE(fs::exists(dir_ / (next + ".part")));
  EXPECT_FALSE(fs::exists(dir_ / "line1-20251128T032010.000Z-emcy.json"));
  EXPECT_TRUE(w.recent().empty());
}

// The cap bounds the space, the budget the writes (flash
// wear). Beyond capture_budget_per_hour a fault opens no capture: it is
// counted, the first skip of the hour is logged, and once the hour is over
// one line gives the hour's count; the next hour has its budget again.
TEST_F(CaptureWriterTest, BeyondTheHoursBudgetACaptureIsSkippedCountedAndLoggedOnce) {
  const GatewayLog log;
  can::FrameRecorder rec(10);
  CaptureOptions o = options();
  o.after = std::chrono::milliseconds(500);
  o.budget_per_hour = 3;
  CaptureWriter w(o, rec);
  std::size_t made = 0;
  for (int i = 0; i < 10; ++i) made += w.request("emcy", "enc1", kT0 + std::int64_t{i} * kSecond).empty() ? 0u : 1u;
  EXPECT_EQ(made, 3u);
  EXPECT_EQ(w.pending(), 3u);
  EXPECT_EQ(w.skipped_over_budget(), 7u);
  // A fault inside a window already open costs nothing.
  EXPECT_FALSE(w.request("emcy", "enc2", kT0 + 2 * kSecond + 100'000'000).empty());
  EXPECT_EQ(w.poll(kT0 + 20 * kSecond).size(), 3u);
  EXPECT_EQ(log.count("bus line1: capture skipped: 3 captures in the hour from 20251128T032000.000Z"), 1u);
  EXPECT_EQ(log.count("capture(s) skipped in the hour"), 0u);
  (void)w.poll(kT0 + 3600 * kSecond);  // the hour is over
  EXPECT_EQ(log.count("bus line1: 7 capture(s) skipped in the hour from 20251128T032000.000Z: "
                      "capture_budget_per_hour = 3"),
            1u);
  EXPECT_FALSE(w.request("emcy", "enc1", kT0 + 3601 * kSecond).empty());
  EXPECT_EQ(w.skipped_over_budget(), 7u);
}

TEST_F(CaptureWriterTest, StartRemovesThisBusesPartialFiles) {
  can::FrameRecorder rec(10);
  std::ofstream(dir_ / "line1-20251128T032015.000Z-emcy.log.part") << "(1.000000) vcan0 081#";
  std::ofstream(dir_ / "line2-20251128T032015.000Z-emcy.log.part") << "another bus's";
  CaptureWriter w(options(), rec);
  ASSERT_TRUE(w.start().ok());
  w.stop();
  EXPECT_FALSE(fs::exists(dir_ / "line1-20251128T032015.000Z-emcy.log.part"));
  EXPECT_TRUE(fs::exists(dir_ / "line2-20251128T032015.000Z-emcy.log.part"));
}

TEST_F(CaptureWriterTest, TheThreadWritesADueCaptureOnItsOwn) {
  can::FrameRecorder rec(10);
  const std::int64_t now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                               std::chrono::system_clock::now().time_since_epoch()).count();
  rec.record(frame_at(now - kSecond, 0x70A, {0x00}));
  CaptureOptions o = options();
  o.after = std::chrono::milliseconds(100);
  CaptureWriter w(o, rec);
  ASSERT_TRUE(w.start().ok());
  w.request("operator", "", now);
  for (int i = 0; i < 50 && w.recent().empty(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  w.stop();
  ASSERT_EQ(w.recent().size(), 1u);
  EXPECT_EQ(w.recent()[0].frames, 1u);
}

}  // namespace
}  // namespace cobridge::bus
