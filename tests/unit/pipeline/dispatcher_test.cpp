// Dispatcher: two bus producers, one consumer thread that sleeps when idle.
#include "pipeline/dispatcher.hpp"

#include "unit/support/eventually.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

using namespace cobridge::pipeline;
using namespace std::chrono_literals;
using cobridge::test::eventually;

namespace {

class RecordingSink : public SampleSink {
 public:
  void deliver(std::span<const Sample> batch) noexcept override {
    for (const Sample& s : batch) {
      const std::size_t bus = s.bus_index;
      if (s.sequence != last[bus] + 1) ++gaps;
      last[bus] = s.sequence;
      if (s.publish_timestamp_ns < s.rx_timestamp_ns) ++bad_time;
    }
    delivered.fetch_add(batch.size(), std::memory_order_relaxed);
  }
  std::uint32_t last[2] = {0, 0};
  int gaps = 0;
  int bad_time = 0;
  std::atomic<std::size_t> delivered{0};
};

}  // namespace

TEST(Dispatcher, DeliversEverySampleInOrderFromTwoProducers) {
  RecordingSink sink;
  Dispatcher d(sink);
  SpscRing<Sample> a(1024), b(1024);
  d.add_source(a);
  d.add_source(b);
  d.start();
  constexpr std::uint32_t kPerBus = 200'000;
  auto produce = [&](SpscRing<Sample>& ring, std::uint8_t bus) {
    Sample s{};
    s.bus_index = bus;
    for (std::uint32_t i = 1; i <= kPerBus; ++i) {
      s.sequence = i;
      s.rx_timestamp_ns = 1;
      while (!ring.try_push(s)) std::this_thread::yield();  // the test wants no loss
      d.wake();
    }
  };
  std::thread t1(produce, std::ref(a), 0), t2(produce, std::ref(b), 1);
  t1.join();
  t2.join();
  d.stop();
  EXPECT_EQ(sink.delivered.load(), 2u * kPerBus);
  EXPECT_EQ(sink.gaps, 0);
  EXPECT_EQ(sink.bad_time, 0);
  EXPECT_EQ(d.stats().samples, 2u * kPerBus);
}

// Idle: the dispatcher sleeps instead of spinning, and one push wakes it.
TEST(Dispatcher, SleepsWhenIdleAndWakesOnPush) {
  RecordingSink sink;
  Dispatcher d(sink);
  SpscRing<Sample> a(64);
  d.add_source(a);
  d.start();
  ASSERT_TRUE(eventually([&] { return d.stats().sleeps >= 1; }, 2s)) << "the idle dispatcher never went to sleep";
  // Not spinning is an absence, watched over a window: asleep, the
  // dispatcher counts one sleep per poll timeout (100 ms) at most; spinning,
  // thousands.
  constexpr auto kIdleWindow = 50ms;
  const auto asleep = d.stats().sleeps;
  const auto watch_start = std::chrono::steady_clock::now();
  std::this_thread::sleep_for(kIdleWindow);
  const auto watched = std::chrono::steady_clock::now() - watch_start;
  const auto timeouts = static_cast<std::uint64_t>(watched / 100ms);
  EXPECT_LE(d.stats().sleeps - asleep, timeouts + 2) << "an idle dispatcher must block, not poll in a loop";
  Sample s{};
  s.sequence = 1;
  ASSERT_TRUE(a.try_push(s));
  const auto t0 = std::chrono::steady_clock::now();
  d.wake();
  EXPECT_TRUE(eventually([&] { return sink.delivered.load() != 0; }, 2s));
  const auto waited = std::chrono::steady_clock::now() - t0;
  EXPECT_EQ(sink.delivered.load(), 1u);
  EXPECT_LT(waited, std::chrono::milliseconds(50)) << "woken by the eventfd, not by the 100 ms poll timeout";
  d.stop();
}

// The daemon starts its receivers and buses while the plugins start: what
// they produce meanwhile waits (samples in the ring, announcements in order)
// and reaches the sink once the dispatcher starts, announcements first.
TEST(Dispatcher, HoldsSamplesAndTasksUntilStarted) {
  struct OrderSink : SampleSink {
    void deliver(std::span<const Sample> batch) noexcept override {
      for (const Sample& s : batch) order.push_back(static_cast<int>(s.sequence));
      delivered.fetch_add(batch.size(), std::memory_order_release);
    }
    std::vector<int> order;  // > 0 a sample's sequence, < 0 a task
    std::atomic<std::size_t> delivered{0};
  } sink;
  Dispatcher d(sink);
  SpscRing<Sample> ring(1024);
  d.add_source(ring);
  d.hold();
  std::atomic<int> tasks_run{0};
  const auto poster = std::this_thread::get_id();
  std::atomic<bool> ran_on_poster{false};
  for (std::uint32_t i = 1; i <= 500; ++i) {
    Sample s{};
    s.sequence = i;
    ASSERT_TRUE(ring.try_push(s));
    d.wake();
    if (i % 100 == 0) {
      d.post([&, i] {
        if (std::this_thread::get_id() == poster) ran_on_poster = true;
        sink.order.push_back(-static_cast<int>(i));
        tasks_run.fetch_add(1, std::memory_order_release);
      });
    }
  }
  // Without hold() each post() would have run its task on this thread, before returning.
  EXPECT_EQ(tasks_run.load(), 0);
  EXPECT_EQ(sink.delivered.load(), 0u);
  d.start();
  EXPECT_TRUE(eventually([&] { return sink.delivered.load(std::memory_order_acquire) == 500; }, 5s));
  EXPECT_EQ(tasks_run.load(std::memory_order_acquire), 5);
  d.stop();
  EXPECT_FALSE(ran_on_poster.load());
  std::vector<int> expected = {-100, -200, -300, -400, -500};
  for (int i = 1; i <= 500; ++i) expected.push_back(i);
  EXPECT_EQ(sink.order, expected);
  EXPECT_EQ(d.stats().samples, 500u);
}
