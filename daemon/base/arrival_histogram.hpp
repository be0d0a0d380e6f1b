// ArrivalHistogram: a histogram of the times between two arrivals of one
// kind of frame from one device (heartbeats, TPDOs), as a value: what the
// output pipeline counts (pipeline/arrival_histograms.hpp) and what the
// status report and /metrics show.
//
// Thread contract: plain value type; any thread.
#pragma once

#include <array>
#include <cstdint>

namespace cobridge {

// Upper bounds of the buckets, in seconds; a last bucket is +Inf. From a
// 1 ms TPDO to a 1 s heartbeat and beyond a consumer time of a few seconds.
inline constexpr std::array<double, 12> kArrivalBounds = {0.001, 0.002, 0.005, 0.01, 0.02, 0.05,
                                                          0.1,   0.2,   0.5,   1.0,  2.0,  5.0};

struct ArrivalHistogram {
  std::array<std::uint64_t, kArrivalBounds.size() + 1> buckets{};  // not cumulative; the last is +Inf
  double sum_s = 0;

  [[nodiscard]] constexpr std::uint64_t count() const noexcept {
    std::uint64_t n = 0;
    for (const std::uint64_t b : buckets) n += b;
    return n;
  }
};

}  // namespace cobridge
