// FrameRecorder: the last N seconds of one bus's frames, for the captures
// written around a fault (the "flight recorder").
//
// A fixed ring of slots, allocated once at construction. The writer (the
// bus's RX thread) stores each frame with record(): a handful of relaxed
// atomic stores, no allocation, lock, system call or logging. A reader on
// another thread copies a time window with snapshot() without stopping the
// writer: every slot carries a sequence (seqlock style) that says which
// frame it holds and whether a write is under way, so a slot overwritten
// while it was copied is detected and skipped (and counted), never returned
// torn. The slots' contents are atomics, so the protocol is also data-race
// free as the C++ memory model (and TSan) define it.
//
// Threads: record() from exactly one thread (the RX thread); snapshot(),
// recorded() and the size figures from any thread.
#pragma once

#include "can/frame.hpp"

#include <atomic>
#include <cstring>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace cobridge::can {

struct RecorderWindow {
  std::vector<Frame> frames;  // oldest first, timestamps within the window
  std::size_t skipped = 0;    // slots the writer overwrote while they were copied
};

class FrameRecorder {
 public:
  // Bits of the shortest classic CAN frame on the wire: a data frame with an
  // 11-bit identifier and no data is 44 bits, plus 3 bits of interframe
  // space (ISO 11898-1). Stuff bits only make frames longer.
  static constexpr std::uint32_t kShortestFrameBits = 47;

  // Slots that hold every frame the bus can carry in `seconds` at
  // `bitrate_kbit` (at least 1).
  [[nodiscard]] static std::size_t capacity_for(std::uint32_t bitrate_kbit, std::uint32_t seconds) noexcept;
  // Bytes a recorder of `capacity` slots holds (what the status reports).
  [[nodiscard]] static std::size_t bytes_for(std::size_t capacity) noexcept;

  explicit FrameRecorder(std::size_t capacity);
  FrameRecorder(const FrameRecorder&) = delete;
  FrameRecorder& operator=(const FrameRecorder&) = delete;

  // RX thread only. Overwrites the oldest frame once the ring is full.
  void record(const Frame& frame) noexcept;

  // Frames with from_ns <= timestamp_ns <= to_ns (ns since the Unix epoch),
  // oldest first. Allocates the vector; not for the hot path.
  [[nodiscard]] RecorderWindow snapshot(std::int64_t from_ns, std::int64_t to_ns) const;

  [[nodiscard]] std::size_t capacity() const noexcept { return capacity_; }
  [[nodiscard]] std::size_t memory_bytes() const noexcept { return bytes_for(capacity_); }
  // Frames recorded since construction (also those overwritten since).
  [[nodiscard]] std::uint64_t recorded() const noexcept { return written_.load(std::memory_order_acquire); }

 private:
  static constexpr std::size_t kWords = sizeof(Frame) / sizeof(std::uint64_t);
  static_assert(sizeof(Frame) % sizeof(std::uint64_t) == 0);
  // seq: 0 = never written, kBusy = a write is under way, else index + 1 of
  // the frame the words hold.
  static constexpr std::uint64_t kBusy = ~std::uint64_t{0};
  struct Slot {
    std::atomic<std::uint64_t> seq{0};
    std::atomic<std::uint64_t> words[kWords];
  };
  // One slot's frame if it still holds frame `index`.
  bool read_slot(std::uint64_t index, Frame& out) const noexcept;

  std::size_t capacity_;
  std::unique_ptr<Slot[]> slots_;
  std::size_t next_slot_ = 0;  // writer's own position (index % capacity without a division)
  std::atomic<std::uint64_t> written_{0};
};

// Inline: the RX thread calls it per frame.
inline void FrameRecorder::record(const Frame& frame) noexcept {
  const std::uint64_t index = written_.load(std::memory_order_relaxed);
  Slot& slot = slots_[next_slot_];
  std::uint64_t words[kWords];
  std::memcpy(words, &frame, sizeof words);
  // Seqlock write side: mark busy, then the payload, then the new sequence.
  slot.seq.store(kBusy, std::memory_order_relaxed);
  std::atomic_thread_fence(std::memory_order_release);
  for (std::size_t i = 0; i < kWords; ++i) slot.words[i].store(words[i], std::memory_order_relaxed);
  slot.seq.store(index + 1, std::memory_order_release);
  written_.store(index + 1, std::memory_order_release);
  if (++next_slot_ == capacity_) next_slot_ = 0;
}

}  // namespace cobridge::can
