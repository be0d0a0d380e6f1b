#include "pipeline/bus_receiver.hpp"

#include "canopen/cob_id.hpp"

#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <array>
#include <ctime>

namespace cobridge::pipeline {
namespace {

std::int64_t monotonic_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000LL + ts.tv_nsec;
}

std::int64_t realtime_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000LL + ts.tv_nsec;
}

// Without a recorder, only what becomes samples: SYNC + EMCY (0x080..0x0FF),
// TPDO1 (0x180..0x1FF), TPDO2 (0x280..0x2FF), error control (0x700..0x77F).
// With one, every frame: the recording must hold the SDO, LSS and NMT
// exchanges around a configuration or commissioning fault, the daemon's own
// requests included (they come from the control thread's socket, and the
// kernel loops a socket's transmissions back to the host's other sockets,
// CAN_RAW_LOOPBACK). The decoder drops what it does not publish (one compare
// chain, counted as `ignored`); the bus carries at most ~21 000 frames/s.
std::span<const can::Filter> receive_filters(bool recorder) noexcept {
  namespace cob = canopen::cob;
  static constexpr can::Filter kSamples[] = {
      {cob::kSync, 0x780, false},
      {cob::kTpdo1Base, 0x780, false},
      {cob::kTpdo2Base, 0x780, false},
      {cob::kNmtErrorControlBase, 0x780, false},
  };
  static constexpr can::Filter kEverything[] = {can::Filter::all_standard(), {0, 0, true}};
  if (recorder) return kEverything;
  return kSamples;
}

}  // namespace

BusReceiver::BusReceiver(BusReceiverOptions options, const DeviceTable& table, Dispatcher& dispatcher)
    : options_(std::move(options)),
      ring_(options_.ring_capacity),
      decoder_(options_.bus_index, table),
      dispatcher_(dispatcher),
      // A missing or re-plugged adapter is waited for, like the bus manager's socket.
      channel_(can::SocketCanConfig{.interface = options_.interface,
                                    .reopen_backoff_max = std::chrono::milliseconds(500),
                                    .receive_buffer_bytes = options_.receive_buffer_bytes,
                                    .wait_for_interface = true}),
      wake_fd_(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC)) {}

BusReceiver::~BusReceiver() {
  stop();
  if (wake_fd_ >= 0) ::close(wake_fd_);
}

Error BusReceiver::start() {
  if (running_.load()) return {};
  if (Error e = channel_.open()) return e;
  if (Error e = channel_.set_filters(receive_filters(options_.recorder != nullptr))) return e;
  // Error frames too: the recorder keeps them (a capture around a bus error
  // holds them); the decoder ignores them.
  channel_.set_deliver_error_frames(options_.recorder != nullptr);
  running_.store(true);
  thread_ = std::thread([this] { run(); });
  return {};
}

void BusReceiver::stop() {
  if (!running_.exchange(false)) return;
  const std::uint64_t one = 1;
  (void)!::write(wake_fd_, &one, sizeof one);
  if (thread_.joinable()) thread_.join();
  channel_.close();
}

bool BusReceiver::post_status(const StatusEvent& e) noexcept {
  if (!status_ring_.try_push(e)) {
    status_drops_.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  const std::uint64_t one = 1;
  (void)!::write(wake_fd_, &one, sizeof one);
  return true;
}

void BusReceiver::push(const Sample& s) noexcept {
  if (!ring_.try_push(s)) ring_drops_.store(ring_drops_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
}

void BusReceiver::refresh_plans() noexcept {
  // New plans take effect between batches, never inside one.
  try {
    decoder_.refresh();
  } catch (...) {
    // A mutex failure would be a broken system; keep the old plans.
  }
}

std::size_t BusReceiver::handle(std::span<const can::Frame> frames) noexcept {
  std::size_t pushed = 0;
  Sample s;
  // The whole batch at once: the recorder's counters move once per batch.
  if (options_.recorder != nullptr) options_.recorder->record(frames);
  for (const can::Frame& f : frames) {
    if (decoder_.decode(f, s)) {
      push(s);
      ++pushed;
    }
  }
  if (pushed) dispatcher_.wake();
  return pushed;
}

void BusReceiver::drain_status() noexcept {
  StatusEvent e;
  Sample s;
  bool any = false;
  while (status_ring_.try_pop(e)) {
    const bool made = e.kind == StatusEvent::Kind::command
                          ? decoder_.make_command(e.node_id, e.command_kind, e.command_status, e.command_tag,
                                                  e.command_abort_code, e.timestamp_ns, s)
                          : decoder_.make_status(e.node_id, e.online, false, e.nmt_state, e.timestamp_ns, s);
    if (made) {
      push(s);
      any = true;
    }
  }
  if (any) dispatcher_.wake();
}

void BusReceiver::run() noexcept {
  std::array<can::Frame, 64> frames;
  std::int64_t next_stale_check = 0;
  while (running_.load(std::memory_order_acquire)) {
    pollfd pfds[2] = {{channel_.fd(), POLLIN, 0}, {wake_fd_, POLLIN, 0}};
    ::poll(pfds, 2, static_cast<int>(options_.stale_check.count()));
    if (pfds[1].revents & POLLIN) {
      std::uint64_t v = 0;
      (void)!::read(wake_fd_, &v, sizeof v);
    }
    refresh_plans();
    for (;;) {
      const std::size_t n = channel_.receive(frames);
      if (n == 0) break;
      // After the read: a plan the control thread published before the
      // device could send (NMT start follows the publish) decodes its frames.
      refresh_plans();
      decoder_.set_clocks(realtime_ns(), monotonic_ns());
      handle(std::span<const can::Frame>(frames.data(), n));
      if (n < frames.size()) break;
    }
    const std::int64_t wall = realtime_ns();
    const std::int64_t now = monotonic_ns();
    decoder_.set_clocks(wall, now);
    drain_status();
    if (now >= next_stale_check) {
      Sample s;
      bool any = false;
      decoder_.check_stale(now, [&](std::uint8_t node) {
        if (decoder_.make_status(node, true, true, COBRIDGE_NMT_OPERATIONAL, wall, s)) {
          push(s);
          any = true;
        }
      });
      if (any) dispatcher_.wake();
      next_stale_check = now + std::chrono::duration_cast<std::chrono::nanoseconds>(options_.stale_check).count();
    }
    (void)channel_.process(std::chrono::steady_clock::now());
  }
}

ReceiverStats BusReceiver::stats() const noexcept {
  return ReceiverStats{decoder_.stats(), ring_drops_.load(std::memory_order_relaxed),
                       channel_.stats().rx_overflow_drops, status_drops_.load(std::memory_order_relaxed)};
}

}  // namespace cobridge::pipeline
