// Dispatcher: the consumer side of every bus's sample ring. It drains the
// rings in batches, stamps the publish time and hands each batch to the
// sink (the plugin host). When every ring is empty it sleeps on an eventfd
// (no spinning: the machines have two cores); producers wake it only when it
// announced that it sleeps, so a busy pipeline costs no syscall per batch.
// Threads: add_source() and hold() before start(); wake() and post() from
// any thread; everything else from the owner thread. The sink runs on the dispatcher
// thread and must not block for long.
#pragma once

#include "pipeline/sample.hpp"
#include "pipeline/spsc_ring.hpp"

#include <atomic>
#include <functional>
#include <mutex>
#include <cstdint>
#include <span>
#include <thread>
#include <vector>

namespace cobridge::pipeline {

class SampleSink {
 public:
  virtual ~SampleSink() = default;
  virtual void deliver(std::span<const Sample> batch) noexcept = 0;
};

struct DispatcherStats {
  std::uint64_t samples = 0;
  std::uint64_t batches = 0;
  std::uint64_t sleeps = 0;
};

class Dispatcher {
 public:
  static constexpr std::size_t kBatch = 256;

  explicit Dispatcher(SampleSink& sink);
  ~Dispatcher();
  Dispatcher(const Dispatcher&) = delete;
  Dispatcher& operator=(const Dispatcher&) = delete;

  void add_source(SpscRing<Sample>& ring);
  // Until start(), what arrives waits for the thread: the samples in their
  // rings, the posted tasks in order (instead of running on the poster's
  // thread). The daemon's receivers and buses start while the plugins are
  // still starting; this keeps every sample and device announcement for the
  // plugins, and none reaches a plugin before its start.
  void hold() noexcept { holding_.store(true, std::memory_order_release); }
  void start();
  // Drains what is left, then joins.
  void stop();

  // Producer side, after a push: wakes the dispatcher if it sleeps.
  void wake() noexcept;

  // Runs `task` on the dispatcher thread before the next batch (plugin.h:
  // on_device is called on the dispatcher thread, like on_samples); neither
  // started nor holding (tests, after stop()), on the caller's thread. Off
  // the hot path: takes a mutex and may allocate. Any thread.
  void post(std::function<void()> task);

  // One pass over all rings on the calling thread; returns samples delivered.
  // For benchmarks and tests that run without the thread.
  std::size_t drain_once() noexcept;

  [[nodiscard]] DispatcherStats stats() const noexcept;

 private:
  void run() noexcept;
  bool any_pending() const noexcept;
  void run_tasks() noexcept;

  SampleSink& sink_;
  std::vector<SpscRing<Sample>*> sources_;
  std::thread thread_;
  int event_fd_ = -1;
  std::atomic<bool> running_{false};
  std::atomic<bool> holding_{false};
  std::atomic<int> sleeping_{0};  // 1 while the dispatcher waits on event_fd_
  std::atomic<std::uint64_t> samples_{0}, batches_{0}, sleeps_{0};
  std::mutex task_mutex_;
  std::vector<std::function<void()>> tasks_;
  std::atomic<bool> tasks_pending_{false};
  Sample batch_[kBatch];
};

}  // namespace cobridge::pipeline
