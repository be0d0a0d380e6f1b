// ArrivalHistograms (docs/web.md "Metrics": cobridge_heartbeat_interval_seconds,
// cobridge_tpdo_interval_seconds): the time between two heartbeats / TPDOs
// of a node, counted on the dispatcher thread without allocation.
#include "pipeline/arrival_histograms.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace cobridge::pipeline {
namespace {

Sample at(SampleKind kind, std::uint8_t bus, std::uint8_t node, std::uint64_t mono_ns) {
  Sample s{};
  s.kind = static_cast<std::uint8_t>(kind);
  s.bus_index = bus;
  s.node_id = node;
  s.rx_timestamp_ns = 1'700'000'000'000'000'000ull + mono_ns;
  s.rx_monotonic_ns = mono_ns;
  s.valid = COBRIDGE_VALID_RX_MONOTONIC;
  return s;
}

// CiA 301 7.2.8.3.2: a heartbeat producer every 100 ms; one arrives 300 ms late.
TEST(ArrivalHistograms, Cia301_7_2_8_3_2_HeartbeatIntervalsFallInTheirBuckets) {
  ArrivalHistograms h(2);
  std::vector<Sample> batch;
  std::uint64_t t = 1'000'000'000;
  for (int i = 0; i < 11; ++i, t += 100'000'000) batch.push_back(at(SampleKind::kHeartbeat, 1, 7, t));
  batch.push_back(at(SampleKind::kHeartbeat, 1, 7, t + 200'000'000));  // 300 ms after the last
  h.record(batch);
  const ArrivalHistogram hb = h.read(1, 7, ArrivalKind::heartbeat);
  EXPECT_EQ(hb.count(), 11u) << "n arrivals, n - 1 intervals";
  EXPECT_EQ(hb.buckets[6], 10u) << "0.05 s < 100 ms <= 0.1 s";
  EXPECT_EQ(hb.buckets[8], 1u) << "0.2 s < 300 ms <= 0.5 s";
  EXPECT_NEAR(hb.sum_s, 1.3, 1e-9);
  EXPECT_EQ(h.read(1, 7, ArrivalKind::tpdo).count(), 0u) << "heartbeats are not TPDOs";
  EXPECT_EQ(h.read(0, 7, ArrivalKind::heartbeat).count(), 0u) << "another bus";
  EXPECT_EQ(h.read(5, 7, ArrivalKind::heartbeat).count(), 0u) << "out of range reads empty";
}

// TPDOs of two nodes interleaved are counted per node; a clock that goes
// back is not an interval.
TEST(ArrivalHistograms, TpdosPerNodeAndNoNegativeIntervals) {
  ArrivalHistograms h(1);
  std::vector<Sample> batch;
  for (std::uint64_t i = 1; i <= 100; ++i) {
    batch.push_back(at(SampleKind::kTpdo, 0, 1, i * 1'000'000));   // 1 ms
    batch.push_back(at(SampleKind::kTpdo, 0, 2, i * 20'000'000));  // 20 ms
  }
  batch.push_back(at(SampleKind::kTpdo, 0, 1, 1'000));  // back in time
  h.record(batch);
  const ArrivalHistogram a = h.read(0, 1, ArrivalKind::tpdo), b = h.read(0, 2, ArrivalKind::tpdo);
  EXPECT_EQ(a.count(), 99u);
  EXPECT_EQ(a.buckets[0], 99u) << "1 ms <= 0.001 s";
  EXPECT_EQ(b.count(), 99u);
  EXPECT_EQ(b.buckets[4], 99u) << "0.01 s < 20 ms <= 0.02 s";
}

}  // namespace
}  // namespace cobridge::pipeline
