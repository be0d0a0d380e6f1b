#include "can/frame_recorder.hpp"

#include <algorithm>
#include <cstring>

namespace cobridge::can {

std::size_t FrameRecorder::capacity_for(std::uint32_t bitrate_kbit, std::uint32_t seconds) noexcept {
  const std::uint64_t per_second = (std::uint64_t{bitrate_kbit} * 1000 + kShortestFrameBits - 1) / kShortestFrameBits;
  return static_cast<std::size_t>(std::max<std::uint64_t>(1, per_second * seconds));
}

std::size_t FrameRecorder::bytes_for(std::size_t capacity) noexcept {
  return (std::max<std::size_t>(1, capacity) + 1) * sizeof(Frame);
}

FrameRecorder::FrameRecorder(std::size_t capacity)
    : capacity_(std::max<std::size_t>(1, capacity)),
      slot_count_(capacity_ + 1),
      words_(std::make_unique<std::uint64_t[]>(slot_count_ * kWords)) {
  // make_unique value-initialises: every page is touched here, so the RX
  // thread takes no page faults later.
}

Frame FrameRecorder::read_slot(std::uint64_t index) const noexcept {
  std::uint64_t* slot = &words_[(index % slot_count_) * kWords];
  std::uint64_t words[kWords];
  // Acquire: the `begun` read after the copy is at least what the writer
  // had published when it wrote any word seen here.
  for (std::size_t i = 0; i < kWords; ++i) words[i] = std::atomic_ref<std::uint64_t>(slot[i]).load(std::memory_order_acquire);
  Frame f;
  std::memcpy(&f, words, sizeof words);
  return f;
}

RecorderWindow FrameRecorder::snapshot(std::int64_t from_ns, std::int64_t to_ns) const {
  RecorderWindow window;
  const std::uint64_t end = written_.load(std::memory_order_acquire);  // frames < end are whole
  const std::uint64_t begin = end > capacity_ ? end - capacity_ : 0;
  std::vector<std::uint64_t> indices;
  for (std::uint64_t i = begin; i < end; ++i) {
    const Frame f = read_slot(i);
    // A torn copy may carry any timestamp: it is dropped below if it is
    // torn, and one outside the window is not wanted anyway.
    if (f.timestamp_ns < from_ns || f.timestamp_ns > to_ns) continue;
    window.frames.push_back(f);
    indices.push_back(i);
  }
  // Slots the writer reached meanwhile (frame i + slots begun) may be torn:
  // frame i is whole only if i + slots >= what has begun now.
  const std::uint64_t begun = begun_.load(std::memory_order_acquire);
  const std::uint64_t first_whole = begun >= slot_count_ ? begun - slot_count_ : 0;
  window.skipped = first_whole > begin ? static_cast<std::size_t>(std::min(first_whole, end) - begin) : 0;
  const auto keep = std::lower_bound(indices.begin(), indices.end(), first_whole) - indices.begin();
  window.frames.erase(window.frames.begin(), window.frames.begin() + keep);
  return window;
}

}  // namespace cobridge::can
