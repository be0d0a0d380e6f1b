// SpscRing: the bounded lock-free queue between a bus RX thread (the single
// producer) and the dispatcher (the single consumer), and between a plugin's
// on_samples (the dispatcher) and the plugin's own writer thread: part of the
// plugin SDK, so the daemon and the plugins share one implementation.
//
// Capacity is fixed at construction (a power of two), storage is allocated
// once, and push/pop never allocate, lock, throw or block. The two indices
// live on separate cache lines, and each side keeps a cached copy of the
// other side's index so that the common case touches only its own line.
// A full ring refuses the push; the producer counts the drop (never silent).
//
// Threads: try_push / free_slots from the producer thread only; try_pop /
// pop_batch / size_approx from the consumer thread only.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <new>
#include <span>
#include <type_traits>

namespace cobridge {

inline constexpr std::size_t kCacheLine = 64;

template <typename T>
class SpscRing {
  static_assert(std::is_trivially_copyable_v<T>, "ring elements are copied with plain stores");

 public:
  // capacity is rounded up to a power of two (at least 2). The slots are not
  // value-initialised (no slot is read before it is written): untouched pages
  // stay unmapped, so a deep ring costs memory only as deep as it is used, and
  // starting costs no page faults (8 MiB zeroed took ~0.5 s under UML).
  explicit SpscRing(std::size_t capacity)
      : mask_(round_up(capacity) - 1), slots_(std::make_unique_for_overwrite<T[]>(mask_ + 1)) {}

  SpscRing(const SpscRing&) = delete;
  SpscRing& operator=(const SpscRing&) = delete;

  [[nodiscard]] std::size_t capacity() const noexcept { return mask_ + 1; }

  // Producer. Returns false (and leaves the ring untouched) when full.
  [[nodiscard]] bool try_push(const T& value) noexcept {
    const std::size_t head = head_.load(std::memory_order_relaxed);
    if (head - tail_cache_ > mask_) {
      tail_cache_ = tail_.load(std::memory_order_acquire);
      if (head - tail_cache_ > mask_) return false;
    }
    slots_[head & mask_] = value;
    head_.store(head + 1, std::memory_order_release);
    return true;
  }

  // Consumer. Returns false when empty.
  [[nodiscard]] bool try_pop(T& out) noexcept {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    if (tail == head_cache_) {
      head_cache_ = head_.load(std::memory_order_acquire);
      if (tail == head_cache_) return false;
    }
    out = slots_[tail & mask_];
    tail_.store(tail + 1, std::memory_order_release);
    return true;
  }

  // Consumer: pops up to out.size() elements in one go; returns how many.
  // One acquire and one release for the whole batch.
  [[nodiscard]] std::size_t pop_batch(std::span<T> out) noexcept {
    const std::size_t tail = tail_.load(std::memory_order_relaxed);
    head_cache_ = head_.load(std::memory_order_acquire);
    std::size_t n = head_cache_ - tail;
    if (n > out.size()) n = out.size();
    for (std::size_t i = 0; i < n; ++i) out[i] = slots_[(tail + i) & mask_];
    if (n != 0) tail_.store(tail + n, std::memory_order_release);
    return n;
  }

  // Either side: a snapshot, exact only when the other side is idle.
  [[nodiscard]] std::size_t size_approx() const noexcept {
    return head_.load(std::memory_order_acquire) - tail_.load(std::memory_order_acquire);
  }

 private:
  static std::size_t round_up(std::size_t n) noexcept {
    std::size_t c = 2;
    while (c < n) c <<= 1;
    return c;
  }

  const std::size_t mask_;
  const std::unique_ptr<T[]> slots_;
  // Producer's line: its index and its cached view of the consumer's.
  alignas(kCacheLine) std::atomic<std::size_t> head_{0};
  std::size_t tail_cache_ = 0;
  // Consumer's line.
  alignas(kCacheLine) std::atomic<std::size_t> tail_{0};
  std::size_t head_cache_ = 0;
  char pad_[kCacheLine - sizeof(std::size_t) * 2] = {};
};

}  // namespace cobridge
