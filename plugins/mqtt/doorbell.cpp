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
  std::atomic_thread_fence(std::memory_order_seq_cst);  // the push before the look at the flag
  if (!sleeping_.load(std::memory_order_relaxed)) return;
  count_.fetch_add(1, std::memory_order_release);
  wakes_.fetch_add(1, std::memory_order_relaxed);
  ::syscall(SYS_futex, word(count_), FUTEX_WAKE_PRIVATE, 1, nullptr, nullptr, 0);
}

void Doorbell::wait(std::chrono::microseconds timeout, const std::function<bool()>& has_work) noexcept {
  const std::uint32_t seen = count_.load(std::memory_order_acquire);
  sleeping_.store(true, std::memory_order_relaxed);
  std::atomic_thread_fence(std::memory_order_seq_cst);  // the flag before the look at the queues
  if (!has_work()) {
    const auto s = std::chrono::duration_cast<std::chrono::seconds>(timeout);
    const timespec ts{static_cast<time_t>(s.count()),
                      static_cast<long>(std::chrono::duration_cast<std::chrono::nanoseconds>(timeout - s).count())};
    // Returns at a ring (count moved: EAGAIN or a wake), at the timeout, or on a signal.
    ::syscall(SYS_futex, word(count_), FUTEX_WAIT_PRIVATE, seen, &ts, nullptr, 0);
  }
  sleeping_.store(false, std::memory_order_relaxed);
}

}  // namespace cobridge::mqtt
