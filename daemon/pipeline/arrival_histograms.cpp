#include "pipeline/arrival_histograms.hpp"

namespace cobridge::pipeline {

ArrivalHistograms::ArrivalHistograms(std::size_t buses)
    : buses_(buses), counters_(std::make_unique<Counters[]>(buses * kNodes * 2)) {}

void ArrivalHistograms::observe(Counters& c, std::uint64_t at_ns) noexcept {
  const std::uint64_t last = c.last_ns;
  c.last_ns = at_ns;
  if (last == 0 || at_ns <= last) return;  // the first one, or a clock that went back
  const std::uint64_t dt = at_ns - last;
  std::size_t i = 0;
  while (i < kArrivalBounds.size() && static_cast<double>(dt) > kArrivalBounds[i] * 1e9) ++i;
  // One writer: load + store is enough and costs no locked instruction.
  c.buckets[i].store(c.buckets[i].load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  c.sum_ns.store(c.sum_ns.load(std::memory_order_relaxed) + dt, std::memory_order_relaxed);
}

void ArrivalHistograms::record(std::span<const Sample> batch) noexcept {
  for (const Sample& s : batch) {
    if (s.bus_index >= buses_ || s.node_id >= kNodes) continue;
    const auto kind = static_cast<SampleKind>(s.kind);
    if (kind != SampleKind::kTpdo && kind != SampleKind::kHeartbeat) continue;
    // The monotonic receive time where the sample has it: a step of the wall
    // clock is not an interval.
    const bool mono = (s.valid & COBRIDGE_VALID_RX_MONOTONIC) != 0;
    const std::size_t k = kind == SampleKind::kTpdo ? 1 : 0;
    observe(counters_[(s.bus_index * kNodes + s.node_id) * 2 + k], mono ? s.rx_monotonic_ns : s.rx_timestamp_ns);
  }
}

ArrivalHistogram ArrivalHistograms::read(std::size_t bus, std::uint8_t node, ArrivalKind kind) const noexcept {
  ArrivalHistogram h;
  if (bus >= buses_ || node >= kNodes) return h;
  const Counters& c = counters_[(bus * kNodes + node) * 2 + static_cast<std::size_t>(kind)];
  for (std::size_t i = 0; i < h.buckets.size(); ++i) h.buckets[i] = c.buckets[i].load(std::memory_order_relaxed);
  h.sum_s = static_cast<double>(c.sum_ns.load(std::memory_order_relaxed)) / 1e9;
  return h;
}

}  // namespace cobridge::pipeline
