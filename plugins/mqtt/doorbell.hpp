// Doorbell: wakes the publisher thread when the dispatcher queued work,
// without a system call on the dispatcher while the publisher is awake.
//
// The publisher used to nap 1 ms whenever its rings were empty, which added
// up to 1 ms to every sample (the mqtt bench: p50 850 us against a bare
// libmosquitto publisher's 141 us). It still has to look at the link every
// so often (role, session, commands from libmosquitto's thread), so its wait
// keeps a timeout; a ring() ends the wait at once.
//
// The pattern is an event count on one word: bit 0 says the sleeper is
// about to sleep, the rest counts rings. The sleeper sets the bit
// (fetch_or), looks at its queues once more, and sleeps on the word only if
// they are still empty; the ringer pushes, then adds a ring (fetch_add) and
// calls the kernel (a futex wake) only when the bit was set. Both are
// read-modify-writes of the same word, so one comes first: a ring after the
// fetch_or sees the bit (and moves the word, so a sleep not yet begun
// returns at once); a ring before it is read by the fetch_or, which then
// sees the push. No push is missed for the whole timeout, and no fence is
// needed (TSan does not model fences).
//
// Thread contract: ring() from one producer thread (the dispatcher: no
// lock, no allocation; a system call only while the consumer sleeps);
// wait() from one consumer thread (the publisher).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>

namespace cobridge::mqtt {

class Doorbell {
 public:
  // Producer, after its push.
  void ring() noexcept;
  // Consumer: sleeps until a ring() or `timeout`, unless `has_work()` says
  // there is something to do (checked after announcing the sleep).
  void wait(std::chrono::microseconds timeout, const std::function<bool()>& has_work) noexcept;
  // How many rings had to call the kernel (the consumer was asleep).
  [[nodiscard]] std::uint64_t wakes() const noexcept { return wakes_.load(std::memory_order_relaxed); }

 private:
  static constexpr std::uint32_t kSleeping = 1;  // bit 0
  static constexpr std::uint32_t kOneRing = 2;   // the count above it
  std::atomic<std::uint32_t> word_{0};  // the futex word
  std::atomic<std::uint64_t> wakes_{0};
};

}  // namespace cobridge::mqtt
