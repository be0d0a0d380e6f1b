// FrameRecorder: the last N seconds of one bus's frames, for the captures
// written around a fault (the "flight recorder").
//
// A fixed ring of slots, allocated once at construction. The writer (the
// bus's RX thread) stores each receive batch with record(): one copy of the
// batch into the slots (wrapping at most once), two counter stores and a
// prefetch of the next batch's slots; no allocation, lock, system call or
// logging. A reader on another thread copies a time window with snapshot()
// without stopping the writer, seqlock style with two frame counters: `begun` (frames below it have started to
// be written; stored, then a release fence, before the batch's slots are
// touched) and `written` (frames below it are whole; a release store after).
// A reader that copied frame j and then sees `begun` beyond j + slots knows
// slot j % slots may have been overwritten meanwhile and drops the copy
// (counted as skipped); frames are never returned torn. One slot more than
// the capacity, so that `capacity` frames are whole while the writer is idle.
//
// The batch is copied with memcpy (vector stores: a 64-frame batch is 1.5 KiB;
// per-word atomic stores took twice as long, docs/performance-notes.md);
// the reader loads words with acquire atomics. That is
// the classic seqlock: a copy that raced the writer is detected and dropped,
// but the C++ model calls the race itself undefined. Under ThreadSanitizer
// the writer stores each word with a release atomic instead, the same
// protocol in its formally race-free form, so TSan checks the protocol.
//
// Threads: record() from exactly one thread (the RX thread); snapshot(),
// recorded() and the size figures from any thread.
#pragma once

#include "can/frame.hpp"

#include <algorithm>
#include <atomic>
#include <cstring>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
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

  // RX thread only: one receive batch, oldest first. Overwrites the oldest
  // frames once the ring is full.
  void record(std::span<const Frame> frames) noexcept;
  void record(const Frame& frame) noexcept { record(std::span<const Frame>(&frame, 1)); }

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
  // Copies `n` frames into the slots from `dst` on (no wrap inside).
  static void store_run(std::uint64_t* dst, const Frame* src, std::size_t n) noexcept;
  void prefetch_next(std::size_t n) noexcept;
  Frame read_slot(std::uint64_t index) const noexcept;

  std::size_t capacity_;     // frames a snapshot can return
  std::size_t slot_count_;   // capacity_ + 1
  std::unique_ptr<std::uint64_t[]> words_;  // slot_count_ * kWords: slot i is words_[i * kWords ..]
  std::size_t next_slot_ = 0;  // writer's own position (index % slot_count_ without a division)
  std::atomic<std::uint64_t> begun_{0};
  std::atomic<std::uint64_t> written_{0};
};

#if defined(__SANITIZE_THREAD__)
#define COBRIDGE_RECORDER_ATOMIC_WORDS 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define COBRIDGE_RECORDER_ATOMIC_WORDS 1
#endif
#endif

// Inline: the RX thread calls it per receive batch.
inline void FrameRecorder::store_run(std::uint64_t* dst, const Frame* src, std::size_t n) noexcept {
#ifdef COBRIDGE_RECORDER_ATOMIC_WORDS
  const auto* bytes = reinterpret_cast<const unsigned char*>(src);
  for (std::size_t i = 0; i < n * kWords; ++i) {
    std::uint64_t w;
    std::memcpy(&w, bytes + i * sizeof w, sizeof w);
    std::atomic_ref<std::uint64_t>(dst[i]).store(w, std::memory_order_release);
  }
#else
  std::memcpy(dst, src, n * sizeof(Frame));
#endif
}

inline void FrameRecorder::record(std::span<const Frame> frames) noexcept {
  const std::uint64_t k = written_.load(std::memory_order_relaxed);
  // Before any slot of the batch changes: a reader that sees one of the
  // batch's words then sees this too (the fence keeps the copy's stores
  // after it; the atomic words' release stores do that under TSan, which
  // does not model fences).
  begun_.store(k + frames.size(), std::memory_order_relaxed);
#ifndef COBRIDGE_RECORDER_ATOMIC_WORDS
  std::atomic_thread_fence(std::memory_order_release);
#endif
  std::size_t done = 0;
  while (done < frames.size()) {
    const std::size_t run = std::min(frames.size() - done, slot_count_ - next_slot_);
    store_run(&words_[next_slot_ * kWords], frames.data() + done, run);
    done += run;
    next_slot_ += run;
    if (next_slot_ == slot_count_) next_slot_ = 0;
  }
  written_.store(k + frames.size(), std::memory_order_release);
  prefetch_next(frames.size());
}

inline void FrameRecorder::prefetch_next(std::size_t n) noexcept {
  // The next batch's slots, fetched now: after a lap of the ring their cache
  // lines are in L3 or memory, and they arrive while this batch is decoded
  // instead of stalling the next copy (10 s at 1 Mbit/s is 5 MiB of slots;
  // the bench's bare path: 1.08-1.10x per frame without this, 1.03-1.05x
  // with it, docs/performance-notes.md). The next batch is guessed to be as
  // long as this one; up to the ring's end.
  const auto first = reinterpret_cast<std::uintptr_t>(&words_[next_slot_ * kWords]);
  const std::uintptr_t end = first + std::min(n, slot_count_ - next_slot_) * sizeof(Frame);
  for (std::uintptr_t line = first & ~std::uintptr_t{63}; line < end; line += 64) {
#if defined(__x86_64__)
    // A loop of __builtin_prefetch alone has no observable effect, and GCC
    // deletes it (C++ forward progress): the instruction itself, SSE, in
    // every x86-64.
    asm volatile("prefetcht0 %0" : : "m"(*reinterpret_cast<const char*>(line)));
#else
    __builtin_prefetch(reinterpret_cast<const void*>(line), 1, 3);
#endif
  }
}

}  // namespace cobridge::can
