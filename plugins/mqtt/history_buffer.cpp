#include "history_buffer.hpp"

namespace cobridge::mqtt {

void HistoryBuffer::reset(std::size_t capacity, std::uint64_t window_ms) {
  slots_ = capacity != 0 ? std::make_unique<Entry[]>(capacity) : nullptr;
  capacity_ = capacity;
  window_ms_ = window_ms;
  head_ = size_ = 0;
}

std::size_t HistoryBuffer::push(std::uint64_t ts_ms, std::span<const Reading> readings) noexcept {
  if (capacity_ == 0 || readings.empty()) return 0;
  std::size_t dropped = 0;
  // Older than the window behind this newest entry: out, oldest first.
  while (size_ != 0 && window_ms_ != 0 && at(0).ts_ms + window_ms_ < ts_ms) {
    head_ = (head_ + 1) % capacity_;
    --size_;
    ++dropped;
  }
  if (size_ == capacity_) {
    head_ = (head_ + 1) % capacity_;
    --size_;
    ++dropped;
  }
  Entry& e = slots_[(head_ + size_) % capacity_];
  e.ts_ms = ts_ms;
  e.count = 0;
  for (const Reading& r : readings) {
    if (e.count == kMaxReadings) break;
    e.ids[e.count] = r.id;
    e.values[e.count] = r.value;
    ++e.count;
  }
  ++size_;
  return dropped;
}

}  // namespace cobridge::mqtt
