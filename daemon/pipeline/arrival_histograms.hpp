// ArrivalHistograms: how regularly each node's heartbeats and TPDOs arrive,
// as Prometheus histograms of the time between two of them, so a device that
// drifts towards its heartbeat consumer time shows before it is lost.
//
// One fixed block of counters per (bus, node-ID, kind), made at
// construction; record() adds to them (no allocation, lock or exception:
// each counter has one writer and is read with relaxed loads, and a reader
// derives the total count from the buckets, so a scrape is always
// self-consistent even when it races a write).
//
// Threads: record() on the dispatcher thread only (after the plugins had
// the batch, beside LastValues); read() from any thread.
#pragma once

#include "base/arrival_histogram.hpp"
#include "pipeline/sample.hpp"

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>

namespace cobridge::pipeline {

enum class ArrivalKind : std::uint8_t { heartbeat = 0, tpdo = 1 };

class ArrivalHistograms {
 public:
  static constexpr std::size_t kNodes = 128;

  explicit ArrivalHistograms(std::size_t buses);

  // Dispatcher thread only.
  void record(std::span<const Sample> batch) noexcept;
  // Any thread. Out of range: an empty histogram.
  [[nodiscard]] ArrivalHistogram read(std::size_t bus, std::uint8_t node, ArrivalKind kind) const noexcept;

 private:
  struct Counters {
    std::array<std::atomic<std::uint64_t>, kArrivalBounds.size() + 1> buckets{};
    std::atomic<std::uint64_t> sum_ns{0};
    std::uint64_t last_ns = 0;  // the writer's own
  };
  void observe(Counters& c, std::uint64_t at_ns) noexcept;

  std::size_t buses_;
  std::unique_ptr<Counters[]> counters_;  // buses_ * kNodes * 2
};

}  // namespace cobridge::pipeline
