// DeviceTable: the decode plans of one bus's devices, written by the bus's
// control thread when a device is (re)configured and read by its RX thread.
//
// The RX thread never reads the shared plans per frame: it keeps its own copy
// and checks one atomic generation counter per batch, taking the mutex only
// in the rare batch after a change. So the hot path is lock-free in steady
// state and the writer never waits on it for longer than one copy.
// Threads: publish()/remove() from the control thread; generation() and
// snapshot() from the RX thread.
#pragma once

#include "pipeline/decode_plan.hpp"

#include <array>
#include <atomic>
#include <cstdint>
#include <mutex>

namespace cobridge::pipeline {

class DeviceTable {
 public:
  static constexpr std::size_t kNodes = 128;  // node-IDs 1..127; slot 0 unused
  using Plans = std::array<DecodePlan, kNodes>;

  void publish(const DecodePlan& plan);
  // The device at `node_id` has `device_index` (known, not yet configured):
  // its EMCY, heartbeats and status are published under it; a plan already
  // there keeps its decoding.
  void publish_index(std::uint8_t node_id, std::uint16_t device_index);
  void remove(std::uint8_t node_id);

  [[nodiscard]] std::uint32_t generation() const noexcept { return generation_.load(std::memory_order_acquire); }
  // Copies every plan and the generation they belong to.
  void snapshot(Plans& out, std::uint32_t& generation) const;
  // How many snapshots were taken (tests: the RX path copies only after a change).
  [[nodiscard]] std::uint32_t snapshots() const noexcept { return snapshots_.load(std::memory_order_relaxed); }

 private:
  mutable std::mutex mutex_;
  Plans plans_{};
  std::atomic<std::uint32_t> generation_{0};
  mutable std::atomic<std::uint32_t> snapshots_{0};
};

}  // namespace cobridge::pipeline
