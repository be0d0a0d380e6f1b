// Doorbell (plugins/mqtt/doorbell.hpp): a ring ends the publisher's wait at
// once; a ring while the publisher is awake costs no system call; no ring is
// lost between the publisher's last look at its queue and its sleep.
#include "doorbell.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

namespace {

using cobridge::mqtt::Doorbell;
using Clock = std::chrono::steady_clock;

TEST(Doorbell, AWaitWithNothingToDoEndsAtTheTimeout) {
  Doorbell bell;
  const auto t0 = Clock::now();
  bell.wait(std::chrono::milliseconds(20), [] { return false; });
  EXPECT_GE(Clock::now() - t0, std::chrono::milliseconds(19));
  EXPECT_EQ(bell.wakes(), 0u);
}

TEST(Doorbell, WorkSeenAfterAnnouncingTheSleepSkipsTheSleep) {
  Doorbell bell;
  const auto t0 = Clock::now();
  bell.wait(std::chrono::seconds(5), [] { return true; });
  EXPECT_LT(Clock::now() - t0, std::chrono::seconds(1));
}

TEST(Doorbell, ARingWhileTheConsumerIsAwakeCallsNoKernel) {
  Doorbell bell;
  for (int i = 0; i < 1000; ++i) bell.ring();
  EXPECT_EQ(bell.wakes(), 0u);
}

TEST(Doorbell, ARingEndsALongWaitAtOnce) {
  Doorbell bell;
  std::atomic<bool> queued{false};
  std::atomic<bool> woke{false};
  Clock::duration waited{};
  std::thread consumer([&] {
    const auto t0 = Clock::now();
    bell.wait(std::chrono::seconds(10), [&] { return queued.load(); });
    waited = Clock::now() - t0;
    woke = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));  // let it fall asleep (a window, not a sync)
  queued = true;
  bell.ring();
  consumer.join();
  EXPECT_TRUE(woke.load());
  EXPECT_LT(waited, std::chrono::seconds(5)) << "the ring, not the 10 s timeout, ended the wait";
}

// The race the fences close: the producer pushes and rings at any moment
// around the consumer's last look. Over many rounds, every push is taken
// well within the timeout (a lost ring would cost the whole second).
TEST(Doorbell, NoRingIsLostAroundTheLastLook) {
  Doorbell bell;
  std::atomic<int> pushed{0};
  std::atomic<int> taken{0};
  int timeouts = 0;  // waits that ran out with a push waiting: a lost ring
  constexpr int kRounds = 2000;
  std::thread consumer([&] {
    while (taken.load() < kRounds) {
      if (taken.load() < pushed.load()) {
        taken.fetch_add(1);
        continue;
      }
      const auto t0 = Clock::now();
      bell.wait(std::chrono::seconds(1), [&] { return taken.load() < pushed.load(); });
      if (Clock::now() - t0 >= std::chrono::milliseconds(900)) ++timeouts;
    }
  });
  const auto t0 = Clock::now();
  for (int i = 0; i < kRounds; ++i) {
    while (taken.load() < i) std::this_thread::yield();
    pushed.fetch_add(1);
    bell.ring();
  }
  consumer.join();
  EXPECT_EQ(taken.load(), kRounds);
  EXPECT_EQ(timeouts, 0) << "a lost ring waits out the 1 s timeout";
  EXPECT_LT(Clock::now() - t0, std::chrono::seconds(60));
}

}  // namespace
