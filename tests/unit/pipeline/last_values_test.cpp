// LastValues: the dispatcher's record of each node's last value, heartbeat
// and stale flag, read by the status report from other threads.
#include "pipeline/last_values.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <thread>
#include <vector>

using cobridge::pipeline::LastValues;
using cobridge::pipeline::make_sample;
using cobridge::pipeline::Sample;
using cobridge::pipeline::SampleKind;

namespace {

Sample tpdo(std::uint8_t bus, std::uint8_t node, std::int64_t pos, std::uint64_t t) {
  Sample s = make_sample(SampleKind::kTpdo, 0, bus, node, t);
  s.valid = COBRIDGE_VALID_POSITION | COBRIDGE_VALID_POSITION_ENG | COBRIDGE_VALID_RX_MONOTONIC;
  s.position = pos;
  s.position_eng = static_cast<double>(pos) / 10.0;
  s.rx_monotonic_ns = t + 1;
  return s;
}

TEST(LastValues, KeepsTheLastValueHeartbeatAndStaleFlagPerNode) {
  LastValues lv(2);
  EXPECT_EQ(lv.read(1, 5).value_wall_ns, 0U);
  Sample hb = make_sample(SampleKind::kHeartbeat, 0, 1, 5, 500);
  hb.valid = COBRIDGE_VALID_NMT_STATE;
  Sample st = make_sample(SampleKind::kStatus, 0, 1, 5, 600);
  st.valid = COBRIDGE_VALID_STATUS;
  st.stale = 1;
  st.online = 1;
  const std::vector<Sample> batch{tpdo(1, 5, 100, 1000), tpdo(1, 5, 200, 2000), hb, st, tpdo(0, 5, 7, 3000)};
  lv.record(batch);
  const auto v = lv.read(1, 5);
  EXPECT_EQ(v.position, 200);
  EXPECT_DOUBLE_EQ(v.position_eng, 20.0);
  EXPECT_EQ(v.value_wall_ns, 2000U);
  EXPECT_EQ(v.value_monotonic_ns, 2001U);
  EXPECT_EQ(v.heartbeat_wall_ns, 500U);
  EXPECT_EQ(v.heartbeat_monotonic_ns, 0U);  // the heartbeat had no monotonic time
  EXPECT_EQ(v.stale, 1);
  EXPECT_EQ(v.status_known, 1);
  EXPECT_EQ(lv.read(0, 5).position, 7);
  // Out of range reads as never seen; out-of-range samples are ignored.
  lv.record(std::vector<Sample>{tpdo(9, 5, 1, 1)});
  EXPECT_EQ(lv.read(9, 5).value_wall_ns, 0U);
  EXPECT_EQ(lv.read(0, 200).value_wall_ns, 0U);
}

// The sequence lock: a reader never sees a torn slot (position and time
// written together), however often the writer updates.
TEST(LastValues, ReadersNeverSeeATornSlot) {
  LastValues lv(1);
  std::atomic<bool> stop{false};
  std::thread writer([&] {
    for (std::int64_t i = 1; !stop.load(); ++i) {
      const Sample s = tpdo(0, 3, i, static_cast<std::uint64_t>(i) * 10);
      lv.record(std::span<const Sample>(&s, 1));
    }
  });
  std::uint64_t reads = 0;
  for (int i = 0; i < 200000; ++i) {
    const auto v = lv.read(0, 3);
    ASSERT_EQ(v.value_wall_ns, static_cast<std::uint64_t>(v.position) * 10);
    ++reads;
  }
  stop = true;
  writer.join();
  EXPECT_EQ(reads, 200000U);
}

}  // namespace
