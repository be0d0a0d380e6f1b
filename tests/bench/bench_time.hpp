// The benches' clocks and percentiles: wall time (comparable across
// processes on one host: a sample's receive stamp against a subscriber's
// arrival), monotonic time for pacing, and the nearest-rank figures each
// bench prints. Any thread.
#pragma once

#include <time.h>

#include <algorithm>
#include <cstdint>
#include <vector>

namespace cobridge::bench {

inline std::uint64_t clock_ns(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1000000000ull + static_cast<std::uint64_t>(ts.tv_nsec);
}
inline std::uint64_t realtime_ns() { return clock_ns(CLOCK_REALTIME); }
inline std::uint64_t mono_ns() { return clock_ns(CLOCK_MONOTONIC); }

inline void sleep_until_mono(std::uint64_t t_ns) {
  const timespec ts{static_cast<time_t>(t_ns / 1000000000ull), static_cast<long>(t_ns % 1000000000ull)};
  clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
}

struct Figures {
  std::uint64_t count = 0, p50 = 0, p99 = 0, p999 = 0, max = 0;
};
// Sorts `v` in place.
inline Figures figures(std::vector<std::uint64_t>& v) {
  Figures f;
  f.count = v.size();
  if (v.empty()) return f;
  std::sort(v.begin(), v.end());
  auto at = [&](double q) { return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))]; };
  f.p50 = at(0.50);
  f.p99 = at(0.99);
  f.p999 = at(0.999);
  f.max = v.back();
  return f;
}

}  // namespace cobridge::bench
