// The truth file (docs/devices.md "Truth file"): exact line format, and the
// flush rules (at the latest 100 ms after a line, and on flush/destruction).
#include "app/truth_writer.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

namespace cobridge::sim {
namespace {

std::string line(const TruthRecord& r, std::string_view iface = "vcan0") {
  char buf[TruthWriter::kMaxLineBytes];
  const std::size_t n = TruthWriter::format(iface, r, buf, sizeof buf);
  return std::string(buf, n);
}

TruthRecord tpdo() {
  TruthRecord r;
  r.serial = 12345;
  r.node_id = 5;
  r.kind = TruthRecord::Kind::tpdo;
  r.pdo = 1;
  r.frame = can::Frame::make(0x185, {0x10, 0x27, 0x00, 0x00, 0xF6, 0xFF});
  r.frame.timestamp_ns = 1700000000123456789;
  r.has_position = true;
  r.position = 10000;
  r.has_speed = true;
  r.speed = -10;
  return r;
}

TEST(TruthWriter, TpdoLine) {
  EXPECT_EQ(line(tpdo()), "1700000000123456789 vcan0 12345 5 tpdo1 185 6 10270000F6FF pos=10000 speed=-10\n");
}

TEST(TruthWriter, CamAreaAndTpdo2) {
  TruthRecord r = tpdo();
  r.pdo = 2;
  r.frame.id = 0x285;
  r.has_speed = false;
  r.cam_state = 3;
  r.work_area_state = 0;
  EXPECT_EQ(line(r), "1700000000123456789 vcan0 12345 5 tpdo2 285 6 10270000F6FF pos=10000 cam=3 area=0\n");
}

// E§9.1 EMCY 0x5051 measurement error with position 0x7FFFFFFC.
TEST(TruthWriter, EmcyLineCarriesTheCode) {
  TruthRecord r;
  r.serial = 7;
  r.node_id = 127;
  r.kind = TruthRecord::Kind::emcy;
  r.frame = can::Frame::make(0xFF, {0x51, 0x50, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00});
  r.frame.timestamp_ns = 42;
  r.emcy_code = 0x5051;
  EXPECT_EQ(line(r, "vcan1"), "42 vcan1 7 127 emcy 0FF 8 5150010000000000 emcy=5051\n");
}

TEST(TruthWriter, BootUpAndEmptyFrames) {
  TruthRecord r;
  r.serial = 4294967295u;
  r.node_id = 255;
  r.kind = TruthRecord::Kind::lss;
  r.frame.id = 0x7E4;
  r.frame.len = 0;
  EXPECT_EQ(line(r), "0 vcan0 4294967295 255 lss 7E4 0 -\n");
  r.kind = TruthRecord::Kind::boot_up;
  r.node_id = 127;
  r.frame = can::Frame::make(0x77F, {0x00});
  EXPECT_EQ(line(r), "0 vcan0 4294967295 127 boot-up 77F 1 00\n");
}

TEST(TruthWriter, NegativeAndExtremePositions) {
  TruthRecord r = tpdo();
  r.position = static_cast<std::int32_t>(0x80000008u);  // E§9.1 underflow sentinel
  r.has_speed = false;
  EXPECT_NE(line(r).find(" pos=-2147483640\n"), std::string::npos);
  r.position = INT64_MIN;
  EXPECT_NE(line(r).find(" pos=-9223372036854775808\n"), std::string::npos);
}

TEST(TruthWriter, FlushesAfter100msAndOnFlush) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  {
    TruthWriter w;
    w.attach(f);
    const canopen::TimePoint t0{std::chrono::seconds(5)};
    EXPECT_EQ(w.process(t0), canopen::kNever);
    w.write("vcan0", tpdo(), t0);
    EXPECT_EQ(std::ftell(f), 0);  // buffered
    EXPECT_EQ(w.process(t0 + std::chrono::milliseconds(50)), t0 + TruthWriter::kFlushPeriod);
    EXPECT_EQ(std::ftell(f), 0);
    EXPECT_EQ(w.process(t0 + std::chrono::milliseconds(100)), canopen::kNever);
    const long after_one = std::ftell(f);
    EXPECT_EQ(after_one, static_cast<long>(line(tpdo()).size()));
    w.write("vcan0", tpdo(), t0 + std::chrono::milliseconds(200));
    w.write("vcan0", tpdo(), t0 + std::chrono::milliseconds(201));
    EXPECT_EQ(w.lines(), 3u);
  }  // destruction flushes
  EXPECT_EQ(std::ftell(f), static_cast<long>(3 * line(tpdo()).size()));
  std::fclose(f);
}

TEST(TruthWriter, FullBufferGoesOutWithoutWaiting) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  TruthWriter w;
  w.attach(f);
  const canopen::TimePoint t0{};
  const std::size_t per_line = line(tpdo()).size();
  const std::size_t n = TruthWriter::kBufferBytes / per_line + 10;
  for (std::size_t i = 0; i < n; ++i) w.write("vcan0", tpdo(), t0);
  EXPECT_GT(std::ftell(f), 0);
  w.flush();
  EXPECT_EQ(std::ftell(f), static_cast<long>(n * per_line));
  std::fclose(f);
}

}  // namespace
}  // namespace cobridge::sim
