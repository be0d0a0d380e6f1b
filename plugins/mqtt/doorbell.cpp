#include "doorbell.hpp"

#include <linux/futex.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

namespace cobridge::mqtt {

namespace {

// std::atomic<uint32_t> is the futex word itself (lock-free, same layout).
static_assert(std::atomic<std::uint32_t>::is_always_lock_free);

std::uint32_t* word(std::atomic<std::uint32_t>& a) noexcept { return reinterpret_cast<std::uint32_t*>(&a); }

}  // namespace

void Doorbell::ring() noexcept {
  // An RMW, not a load: if it comes after the sleeper's fetch_or it sees the
  // flag; if before, the sleeper's fetch_or reads from it and so sees the push.
  const std::uint32_t prev = word_.fetch_add(kOneRing, std::memory_order_acq_rel);
  if ((prev & kSleeping) == 0) return;
  wakes_.fetch_add(1, std::memory_order_relaxed);
  ::syscall(SYS_futex, word(word_), FUTEX_WAKE_PRIVATE, 1, nullptr, nullptr, 0);
}

void Doorbell::wait(std::chrono::microseconds timeout, const std::function<bool()>& has_work) noexcept {
  const std::uint32_t seen = word_.fetch_or(kSleeping, std::memory_order_acq_rel) | kSleeping;
  if (!has_work()) {
    const auto s = std::chrono::duration_cast<std::chrono::seconds>(timeout);
    const timespec ts{static_cast<time_t>(s.count()),
                      static_cast<long>(std::chrono::duration_cast<std::chrono::nanoseconds>(timeout - s).count())};
    // Returns at a ring (the word moved: EAGAIN or a wake), at the timeout, or on a signal.
    ::syscall(SYS_futex, word(word_), FUTEX_WAIT_PRIVATE, seen, &ts, nullptr, 0);
  }
  word_.fetch_and(~kSleeping, std::memory_order_relaxed);
}

}  // namespace cobridge::mqtt
