// SpscRing throughput: one thread (push then pop, the cost floor) and two
// threads (producer and consumer on the two cores, the real hot-path shape).
// Prints figures; not a test. Run: build/tests/bench/cobridge_bench_spsc_ring
#include "can/frame.hpp"
#include "pipeline/spsc_ring.hpp"

#include <benchmark/benchmark.h>

#include <atomic>
#include <thread>

using cobridge::can::Frame;
using cobridge::pipeline::SpscRing;

static void BM_RingPushPopSameThread(benchmark::State& state) {
  SpscRing<Frame> ring(1024);
  Frame f = Frame::make(0x181, {1, 2, 3, 4, 5, 6});
  Frame out;
  for (auto _ : state) {
    benchmark::DoNotOptimize(ring.try_push(f));
    benchmark::DoNotOptimize(ring.try_pop(out));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RingPushPopSameThread);

static void BM_RingTwoThreads(benchmark::State& state) {
  constexpr std::size_t kBatch = 64;
  for (auto _ : state) {
    SpscRing<Frame> ring(4096);
    const std::size_t total = static_cast<std::size_t>(state.range(0));
    std::atomic<bool> go{false};
    std::thread consumer([&] {
      Frame batch[kBatch];
      std::size_t got = 0;
      while (!go.load(std::memory_order_acquire)) {}
      while (got < total) got += ring.pop_batch(batch);
    });
    go.store(true, std::memory_order_release);
    Frame f = Frame::make(0x181, {1, 2, 3, 4});
    for (std::size_t i = 0; i < total; ++i) {
      f.data[4] = static_cast<uint8_t>(i);
      while (!ring.try_push(f)) {}
    }
    consumer.join();
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_RingTwoThreads)->Arg(1'000'000)->Unit(benchmark::kMillisecond)->UseRealTime();

BENCHMARK_MAIN();
