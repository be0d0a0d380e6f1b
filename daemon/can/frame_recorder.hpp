// FrameRecorder: the last N seconds of one bus's frames, for the captures
// written around a fault (the "flight recorder").
//
// A fixed ring of slots, allocated once at construction. The writer (the
// bus's RX thread) stores each frame with record(): four atomic stores
// (plain moves on x86), no allocation, lock, system call or logging. A
// reader on another thread copies a time window with snapshot() without
// stopping the writer, seqlock style with the frame counter as the
// sequence: the writer publishes "frame k is being written" (the counter
// at k) before it touches slot k % slots, so a reader that copied frame j
// and then sees the counter at j + slots or beyond knows the copy may be
// torn and drops it (counted as skipped); frames are never returned torn.
// One slot more than the capacity: the slot the next frame goes into, so
// that `capacity` frames are whole while the writer is idle. The slots' words are atomics (release stores, acquire loads), so
// the protocol is data-race free as the C++ memory model and TSan define
// it, without fences.
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
  // Frames recorded since construction (also those overwritten since);
  // frame k (0-based) is in slot k % capacity.
  [[nodiscard]] std::uint64_t recorded() const noexcept { return written_.load(std::memory_order_acquire); }

 private:
  static constexpr std::size_t kWords = sizeof(Frame) / sizeof(std::uint64_t);
  static_assert(sizeof(Frame) % sizeof(std::uint64_t) == 0);
  struct Slot {
    std::atomic<std::uint64_t> words[kWords];
  };
  Frame read_slot(std::uint64_t index) const noexcept;

  std::size_t capacity_;     // frames a snapshot can return
  std::size_t slot_count_;   // capacity_ + 1
  std::unique_ptr<Slot[]> slots_;
  std::size_t next_slot_ = 0;  // writer's own position (index % slot_count_ without a division)
  std::atomic<std::uint64_t> written_{0};
};

// Inline: the RX thread calls it per frame.
inline void FrameRecorder::record(const Frame& frame) noexcept {
  // written_ already says k (this frame's index) since the last call: a
  // reader that sees any of these words sees that too (release stores), and
  // so knows slot k % capacity is no longer frame k - capacity.
  Slot& slot = slots_[next_slot_];
  std::uint64_t words[kWords];
  std::memcpy(words, &frame, sizeof words);
  for (std::size_t i = 0; i < kWords; ++i) slot.words[i].store(words[i], std::memory_order_release);
  written_.store(written_.load(std::memory_order_relaxed) + 1, std::memory_order_release);
  if (++next_slot_ == slot_count_) next_slot_ = 0;
}

}  // namespace cobridge::can
