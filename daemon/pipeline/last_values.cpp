#include "pipeline/last_values.hpp"

#include <cstring>

namespace cobridge::pipeline {

LastValues::LastValues(std::size_t buses)
    : buses_(buses), slots_(std::make_unique<Slot[]>(buses * kNodes)), shadow_(std::make_unique<LastValue[]>(buses * kNodes)) {}

// Sequence lock with read-modify-writes instead of fences (GCC 12 refuses
// atomic_thread_fence under TSan): the acquire RMW keeps the word stores
// after the odd count, the release store publishes them with the even one;
// the reader's release RMW keeps its word loads before its second look.
void LastValues::publish(Slot& slot, const LastValue& v) noexcept {
  std::array<std::uint64_t, kWords> w{};
  std::memcpy(w.data(), &v, sizeof v);
  const std::uint32_t s = slot.seq.fetch_add(1, std::memory_order_acquire);
  for (std::size_t i = 0; i < kWords; ++i) slot.words[i].store(w[i], std::memory_order_relaxed);
  slot.seq.store(s + 2, std::memory_order_release);
}

void LastValues::record(std::span<const Sample> batch) noexcept {
  constexpr std::uint16_t kValueBits = COBRIDGE_VALID_POSITION | COBRIDGE_VALID_POSITION_ENG | COBRIDGE_VALID_SPEED;
  for (const Sample& s : batch) {
    if (s.bus_index >= buses_ || s.node_id >= kNodes) continue;
    const std::size_t i = s.bus_index * kNodes + s.node_id;
    LastValue& v = shadow_[i];
    const bool mono = (s.valid & COBRIDGE_VALID_RX_MONOTONIC) != 0;
    switch (static_cast<SampleKind>(s.kind)) {
      case SampleKind::kTpdo:
        if ((s.valid & kValueBits) == 0) continue;
        v.valid = static_cast<std::uint16_t>(s.valid & kValueBits);
        v.position = s.position;
        v.position_eng = s.position_eng;
        v.speed = s.speed;
        v.value_wall_ns = s.rx_timestamp_ns;
        v.value_monotonic_ns = mono ? s.rx_monotonic_ns : 0;
        v.stale = 0;  // a new value is fresh again, as the decoder and SCADA see it
        break;
      case SampleKind::kHeartbeat:
        v.heartbeat_wall_ns = s.rx_timestamp_ns;
        v.heartbeat_monotonic_ns = mono ? s.rx_monotonic_ns : 0;
        break;
      case SampleKind::kStatus:
        if ((s.valid & COBRIDGE_VALID_STATUS) == 0) continue;
        v.stale = s.stale;
        v.online = s.online;
        v.status_known = 1;
        break;
      default:
        continue;
    }
    publish(slots_[i], v);
  }
}

LastValue LastValues::read(std::size_t bus, std::uint8_t node) const noexcept {
  LastValue v{};
  if (bus >= buses_ || node >= kNodes) return v;
  const Slot& slot = slots_[bus * kNodes + node];
  std::array<std::uint64_t, kWords> w{};
  while (true) {
    const std::uint32_t s1 = slot.seq.load(std::memory_order_acquire);
    if ((s1 & 1U) != 0) continue;
    for (std::size_t i = 0; i < kWords; ++i) w[i] = slot.words[i].load(std::memory_order_relaxed);
    if (slot.seq.fetch_add(0, std::memory_order_release) == s1) break;
  }
  std::memcpy(static_cast<void*>(&v), w.data(), sizeof v);
  return v;
}

}  // namespace cobridge::pipeline
