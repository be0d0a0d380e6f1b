#include "can/frame_recorder.hpp"

#include <algorithm>
#include <cstring>

namespace cobridge::can {

std::size_t FrameRecorder::capacity_for(std::uint32_t bitrate_kbit, std::uint32_t seconds) noexcept {
  const std::uint64_t per_second = (std::uint64_t{bitrate_kbit} * 1000 + kShortestFrameBits - 1) / kShortestFrameBits;
  return static_cast<std::size_t>(std::max<std::uint64_t>(1, per_second * seconds));
}

std::size_t FrameRecorder::bytes_for(std::size_t capacity) noexcept { return capacity * sizeof(Slot); }

FrameRecorder::FrameRecorder(std::size_t capacity)
    : capacity_(std::max<std::size_t>(1, capacity)), slots_(std::make_unique<Slot[]>(capacity_)) {
  for (std::size_t i = 0; i < capacity_; ++i)
    for (auto& w : slots_[i].words) w.store(0, std::memory_order_relaxed);
}

bool FrameRecorder::read_slot(std::uint64_t index, Frame& out) const noexcept {
  const Slot& slot = slots_[index % capacity_];
  const std::uint64_t before = slot.seq.load(std::memory_order_acquire);
  if (before != index + 1) return false;
  std::uint64_t words[kWords];
  for (std::size_t i = 0; i < kWords; ++i) words[i] = slot.words[i].load(std::memory_order_relaxed);
  std::atomic_thread_fence(std::memory_order_acquire);
  if (slot.seq.load(std::memory_order_relaxed) != before) return false;
  std::memcpy(&out, words, sizeof words);
  return true;
}

RecorderWindow FrameRecorder::snapshot(std::int64_t from_ns, std::int64_t to_ns) const {
  RecorderWindow window;
  const std::uint64_t end = written_.load(std::memory_order_acquire);
  const std::uint64_t begin = end > capacity_ ? end - capacity_ : 0;
  Frame f;
  for (std::uint64_t i = begin; i < end; ++i) {
    if (!read_slot(i, f)) {
      ++window.skipped;
      continue;
    }
    if (f.timestamp_ns >= from_ns && f.timestamp_ns <= to_ns) window.frames.push_back(f);
  }
  return window;
}

}  // namespace cobridge::can
