#include "pipeline/dispatcher.hpp"

#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <ctime>

namespace cobridge::pipeline {
namespace {

std::uint64_t realtime_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ull + static_cast<std::uint64_t>(ts.tv_nsec);
}

}  // namespace

Dispatcher::Dispatcher(SampleSink& sink) : sink_(sink), event_fd_(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {}

Dispatcher::~Dispatcher() {
  stop();
  if (event_fd_ >= 0) ::close(event_fd_);
}

void Dispatcher::add_source(SpscRing<Sample>& ring) { sources_.push_back(&ring); }

void Dispatcher::start() {
  if (running_.exchange(true)) return;
  thread_ = std::thread([this] { run(); });
}

void Dispatcher::stop() {
  holding_.store(false, std::memory_order_release);
  if (!running_.exchange(false)) return;
  const std::uint64_t one = 1;
  (void)!::write(event_fd_, &one, sizeof one);
  if (thread_.joinable()) thread_.join();
  // Whatever the producers pushed before they stopped still goes out.
  while (drain_once() != 0) {
  }
}

void Dispatcher::wake() noexcept {
  // A read-modify-write on sleeping_ (value unchanged) pairs with the
  // exchange in run(): RMWs on one atomic are totally ordered, so either we
  // read "sleeping" and wake it, or our RMW comes first and releases the
  // pushed sample to the dispatcher's exchange, which then finds it when it
  // re-checks the rings. (No thread fence: TSan cannot model those.)
  if (sleeping_.fetch_add(0, std::memory_order_acq_rel) != 0) {
    const std::uint64_t one = 1;
    (void)!::write(event_fd_, &one, sizeof one);
  }
}

void Dispatcher::post(std::function<void()> task) {
  {
    std::lock_guard lock(task_mutex_);
    tasks_.push_back(std::move(task));
  }
  tasks_pending_.store(true, std::memory_order_release);
  if (!running_.load(std::memory_order_acquire) && !holding_.load(std::memory_order_acquire)) {
    run_tasks();  // not started (or stopped): run here, there is no other consumer
    return;
  }
  // Also when holding: the count waits in the eventfd, so a thread starting
  // right now cannot sleep past this task.
  const std::uint64_t one = 1;
  (void)!::write(event_fd_, &one, sizeof one);
}

void Dispatcher::run_tasks() noexcept {
  if (!tasks_pending_.load(std::memory_order_acquire)) return;
  std::vector<std::function<void()>> todo;
  try {
    std::lock_guard lock(task_mutex_);
    todo.swap(tasks_);
    tasks_pending_.store(false, std::memory_order_relaxed);
  } catch (...) {
    return;
  }
  for (auto& t : todo) {
    try {
      t();
    } catch (...) {
      // A task is plugin bookkeeping; one that throws must not stop delivery.
    }
  }
}

bool Dispatcher::any_pending() const noexcept {
  if (tasks_pending_.load(std::memory_order_acquire)) return true;
  for (const auto* r : sources_)
    if (r->size_approx() != 0) return true;
  return false;
}

std::size_t Dispatcher::drain_once() noexcept {
  run_tasks();
  std::size_t total = 0;
  for (auto* ring : sources_) {
    for (;;) {
      const std::size_t n = ring->pop_batch(std::span<Sample>(batch_, kBatch));
      if (n == 0) break;
      const std::uint64_t now = realtime_ns();
      for (std::size_t i = 0; i < n; ++i) batch_[i].publish_timestamp_ns = now;
      sink_.deliver(std::span<const Sample>(batch_, n));
      total += n;
      batches_.store(batches_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
      if (n < kBatch) break;
    }
  }
  if (total) samples_.store(samples_.load(std::memory_order_relaxed) + total, std::memory_order_relaxed);
  return total;
}

void Dispatcher::run() noexcept {
  while (running_.load(std::memory_order_acquire)) {
    if (drain_once() != 0) continue;
    (void)sleeping_.exchange(1, std::memory_order_acq_rel);
    if (!any_pending() && running_.load(std::memory_order_acquire)) {
      sleeps_.store(sleeps_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
      pollfd pfd{event_fd_, POLLIN, 0};
      ::poll(&pfd, 1, 100);
      std::uint64_t v = 0;
      (void)!::read(event_fd_, &v, sizeof v);
    }
    sleeping_.store(0, std::memory_order_relaxed);
  }
}

DispatcherStats Dispatcher::stats() const noexcept {
  return DispatcherStats{samples_.load(std::memory_order_relaxed), batches_.load(std::memory_order_relaxed),
                         sleeps_.load(std::memory_order_relaxed)};
}

}  // namespace cobridge::pipeline
