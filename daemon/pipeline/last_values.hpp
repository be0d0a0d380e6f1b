// LastValues: the latest value, heartbeat and stale/online flag of every
// node of every bus, as the dispatcher delivered them to the plugins, for
// readers off the data path (the status report behind `cobridge status`,
// the web page and /metrics).
//
// One slot per (bus, node-ID), made at construction; record() only copies
// into slots (no allocation, no lock, no exception), each slot guarded by a
// sequence lock, so a reader never holds the writer up: it retries instead.
//
// Threads: record() is called by one thread only, the dispatcher, after the
// plugins had the batch; read() from any thread.
#pragma once

#include "pipeline/sample.hpp"

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>

namespace cobridge::pipeline {

// What is known of one node. Times are the samples' receive times; 0 = never.
struct LastValue {
  std::uint64_t value_wall_ns = 0;        // last TPDO with a position or speed
  std::uint64_t value_monotonic_ns = 0;   // same, CLOCK_MONOTONIC (0 if the sample had none)
  std::uint64_t heartbeat_monotonic_ns = 0;
  std::uint64_t heartbeat_wall_ns = 0;
  std::int64_t position = 0;
  double position_eng = 0;
  std::int32_t speed = 0;
  std::uint16_t valid = 0;  // COBRIDGE_VALID_POSITION / _POSITION_ENG / _SPEED of the last TPDO
  std::uint8_t stale = 0;   // the last STATUS sample said stale, and no TPDO came since
  std::uint8_t online = 0;
  std::uint8_t status_known = 0;  // a STATUS sample was seen
  std::uint8_t pad_[7] = {};
};
static_assert(std::is_trivially_copyable_v<LastValue>);
static_assert(sizeof(LastValue) % 8 == 0);

class LastValues {
 public:
  static constexpr std::size_t kNodes = 128;  // node-IDs 0..127

  explicit LastValues(std::size_t buses);

  // Dispatcher thread only.
  void record(std::span<const Sample> batch) noexcept;
  // Any thread. A bus or node out of range reads as never seen.
  [[nodiscard]] LastValue read(std::size_t bus, std::uint8_t node) const noexcept;

 private:
  static constexpr std::size_t kWords = sizeof(LastValue) / 8;
  struct Slot {
    mutable std::atomic<std::uint32_t> seq{0};  // read() does an RMW on it
    std::array<std::atomic<std::uint64_t>, kWords> words{};
  };
  void publish(Slot& slot, const LastValue& v) noexcept;

  std::size_t buses_;
  std::unique_ptr<Slot[]> slots_;         // buses_ * kNodes
  std::unique_ptr<LastValue[]> shadow_;   // the writer's own copy, read-modify-write without atomics
};

}  // namespace cobridge::pipeline
