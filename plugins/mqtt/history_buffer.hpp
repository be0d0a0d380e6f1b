// HistoryBuffer: one device's DDATA taken while the edge node cannot
// publish (broker away, primary host offline), kept for store and forward
// (Sparkplug 3.0 5.x "Edge Node and Device Store and Forward": sent after
// the next births as metrics with is_historical = true, in order).
//
// A fixed ring of entries (a frame's receive time and the metrics that
// changed), allocated once by reset() when the device is first told about;
// push() never allocates. When it is full, or when an entry is older than
// the configured window behind the newest, the oldest entries are dropped
// and counted: the host then sees a gap in the history, never a reordering.
//
// Thread contract: the plugin's publisher thread only.
#pragma once

#include "sparkplug_metrics.hpp"

#include <array>
#include <cstdint>
#include <memory>
#include <span>

namespace cobridge::mqtt {

class HistoryBuffer {
 public:
  static constexpr std::size_t kMaxReadings = 13;  // every process metric once

  struct Entry {
    std::uint64_t ts_ms = 0;
    std::uint8_t count = 0;
    std::array<DeviceMetric, kMaxReadings> ids{};
    std::array<Scalar, kMaxReadings> values{};
  };

  // Room for `capacity` entries, none older than `window_ms` behind the
  // newest. capacity 0: stores nothing. Allocates; drops what it held.
  void reset(std::size_t capacity, std::uint64_t window_ms);

  // Appends one entry; returns how many old entries it dropped for it.
  [[nodiscard]] std::size_t push(std::uint64_t ts_ms, std::span<const Reading> readings) noexcept;

  [[nodiscard]] std::size_t size() const noexcept { return size_; }
  [[nodiscard]] std::size_t capacity() const noexcept { return capacity_; }
  // The i-th oldest entry, i < size().
  [[nodiscard]] const Entry& at(std::size_t i) const noexcept { return slots_[(head_ + i) % capacity_]; }
  void clear() noexcept { head_ = size_ = 0; }

 private:
  std::unique_ptr<Entry[]> slots_;
  std::size_t capacity_ = 0;
  std::uint64_t window_ms_ = 0;
  std::size_t head_ = 0;  // oldest
  std::size_t size_ = 0;
};

}  // namespace cobridge::mqtt
