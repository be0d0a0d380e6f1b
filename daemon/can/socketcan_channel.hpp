// can::SocketCanChannel: one CAN_RAW socket on one Linux CAN interface.
//
// The daemon's only door to the bus. Frames come in batches (recvmmsg) with
// the kernel receive time; error frames are not handed out as data but
// decoded into BusEvents; sending never blocks longer than a configured bound
// (the caller decides what to do with a refused frame). When the interface
// goes down or vanishes the channel reports InterfaceDown and closes its
// socket; process(now) then reopens it with backoff and reports
// InterfaceReopened once frames can flow again.
//
// Thread contract: one thread owns a channel (the bus thread) and makes every
// call except stats(); the channel is not thread-safe. stats() may be read
// from any thread (single-writer relaxed counters). receive() and send() are
// the hot path: no allocation, no logging, no exceptions. open() and
// process() may log through the "can" spdlog logger.
#pragma once

#include "base/error.hpp"

#include <linux/can.h>
#include <sys/socket.h>
#include <sys/uio.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <ctime>
#include <span>
#include <string>
#include <system_error>
#include <vector>

#include "can/bus_event.hpp"
#include "can/bus_port.hpp"
#include "can/frame.hpp"

namespace cobridge::can {

// An acceptance filter: a received frame passes when
// (frame.id & mask) == (id & mask) and its format (11/29 bit) equals
// `extended`. Data and remote frames both pass.
struct Filter {
  uint32_t id = 0;
  uint32_t mask = 0;
  bool extended = false;

  static constexpr Filter exact(uint32_t cob_id) noexcept { return Filter{cob_id, 0x7FF, false}; }
  static constexpr Filter all_standard() noexcept { return Filter{0, 0, false}; }
};

// The kernel form of a filter (CAN_RAW_FILTER, kernel SocketCAN documentation
// "RAW socket option CAN_RAW_FILTER"). Exposed for unit tests.
[[nodiscard]] can_filter to_linux(const Filter& filter) noexcept;
// Frame <-> struct can_frame. Error frames keep their class bits in Frame::id.
[[nodiscard]] can_frame to_linux(const Frame& frame) noexcept;
[[nodiscard]] Frame from_linux(const can_frame& cf, int64_t timestamp_ns) noexcept;

struct SocketCanConfig {
  std::string interface;  // e.g. "can0", "vcan0"
  // Longest time send() waits for the kernel to take a frame before giving up.
  std::chrono::microseconds tx_timeout{std::chrono::milliseconds(10)};
  // Reopen backoff after the interface went down: first, then doubling to max.
  std::chrono::milliseconds reopen_backoff_min{100};
  std::chrono::milliseconds reopen_backoff_max{2000};
  // How often process() checks IFF_UP while open, in case the socket error
  // that normally announces a down interface was missed.
  std::chrono::milliseconds link_check_period{1000};
  // SO_RCVBUF in bytes; 0 keeps the kernel default (the kernel doubles it).
  int receive_buffer_bytes = 0;
  // CAN_RAW_ERR_FILTER class bits; all of them by default.
  uint32_t error_mask = CAN_ERR_MASK;
  // An interface that does not exist (a USB adapter not plugged in yet, or
  // unplugged) is waited for like one that is down: open() succeeds closed,
  // process() opens it when it appears. Off: open() fails with ENODEV (CLI).
  bool wait_for_interface = false;
  // Error frames are decoded into bus events and, by default, not handed
  // out with the data frames; a flight recorder's socket wants them too
  // (the frames a capture around a bus error must hold).
  bool deliver_error_frames = false;
};


// open() and set_filters() fail with the project's Error: where = the
// interface name, message = the failing step and the errno text, code = the
// errno (system_category); kind kUnavailable (the interface is not there or
// not usable), kInvalidArgument for a name that cannot be an interface name.

namespace detail {
// CMSG_SPACE without the old-style casts of the libc macro.
constexpr std::size_t cmsg_align(std::size_t n) noexcept {
  return (n + sizeof(std::size_t) - 1) & ~(sizeof(std::size_t) - 1);
}
constexpr std::size_t cmsg_space(std::size_t n) noexcept { return cmsg_align(sizeof(cmsghdr)) + cmsg_align(n); }
}  // namespace detail

class SocketCanChannel final : public BusPort {
 public:

  static constexpr std::size_t kBatch = 64;          // frames per recvmmsg call
  static constexpr std::size_t kEventCapacity = 64;  // events kept between take_events()

  explicit SocketCanChannel(SocketCanConfig config);
  ~SocketCanChannel() override;
  SocketCanChannel(const SocketCanChannel&) = delete;
  SocketCanChannel& operator=(const SocketCanChannel&) = delete;

  // Opens the socket. Fails when the interface does not exist or is not a CAN
  // interface, or a socket call fails. An interface that exists but is down
  // is not a failure: the channel starts closed, reports InterfaceDown and
  // process() opens it once the interface is up.
  [[nodiscard]] Error open();
  void close() noexcept override;

  [[nodiscard]] bool is_open() const noexcept override { return fd_ >= 0; }
  // The socket for poll/epoll, -1 while closed. It changes across a reopen:
  // re-register it after InterfaceDown / InterfaceReopened events.
  [[nodiscard]] int fd() const noexcept override { return fd_; }
  [[nodiscard]] const std::string& interface() const noexcept { return config_.interface; }

  // SocketCanConfig::deliver_error_frames, for an owner that learns after
  // construction whether it wants them (before open() or between receives).
  void set_deliver_error_frames(bool on) noexcept { config_.deliver_error_frames = on; }

  // Replaces the kernel acceptance filters (applied again after a reopen).
  // An empty span receives no data frames; the default after open() is
  // everything. Error frames are unaffected (see SocketCanConfig::error_mask).
  [[nodiscard]] Error set_filters(std::span<const Filter> filters);

  // Reads up to out.size() data frames without blocking. Returns 0 only when
  // nothing is left to read (or the channel is closed). Error frames are
  // decoded into events instead; check take_events() after each call.
  [[nodiscard]] std::size_t receive(std::span<Frame> out) noexcept override;

  // FrameSink: waits at most config.tx_timeout when the kernel queue is full;
  // returns false (counted in tx_dropped) if the frame was not taken.
  [[nodiscard]] bool send(const Frame& frame) noexcept override;

  // Reopens a closed channel when its backoff has elapsed; checks the link
  // of an open one and refreshes rx_overflow_drops from SO_MEMINFO once per
  // link_check_period (not per call). Returns when it wants to be called again.
  TimePoint process(TimePoint now) override;

  // Events since the previous call, oldest first. The span stays valid until
  // the next take_events().
  [[nodiscard]] std::span<const BusEvent> take_events() noexcept override;

  [[nodiscard]] ChannelStats stats() const noexcept override;

 private:
  struct Counter {
    std::atomic<uint64_t> v{0};
    void add(uint64_t n) noexcept { v.store(v.load(std::memory_order_relaxed) + n, std::memory_order_relaxed); }
    void set(uint64_t n) noexcept { v.store(n, std::memory_order_relaxed); }
    [[nodiscard]] uint64_t get() const noexcept { return v.load(std::memory_order_relaxed); }
  };

  // Room for SCM_TIMESTAMPNS and SO_RXQ_OVFL, with slack for anything else
  // the kernel adds (it truncates rather than overflows, MSG_CTRUNC).
  static constexpr std::size_t kControlBytes = detail::cmsg_space(sizeof(timespec)) +
                                               detail::cmsg_space(sizeof(uint32_t)) + 64;

  struct OpenOutcome {
    Error error;
    bool interface_down = false;  // exists but not up (or went down while opening)
    bool missing = false;         // with interface_down: does not exist (wait_for_interface)
  };
  OpenOutcome open_socket();
  int set_socket_options(int fd, const char*& what) const;
  void log_pending() noexcept;
  [[nodiscard]] bool apply_filters() noexcept;
  void went_down(int err) noexcept;
  void close_socket() noexcept;
  void push_event(const BusEvent& event) noexcept;
  void push_interface_event(BusEventKind kind) noexcept;
  void note_overflow_total(uint32_t total) noexcept;
  void mark_drops_before(Frame& f, uint32_t total) noexcept;
  void refresh_overflow_from_meminfo() noexcept;
  [[nodiscard]] bool wait_writable(int err, Clock::time_point deadline) noexcept;

  SocketCanConfig config_;
  int fd_ = -1;
  std::vector<can_filter> filters_;  // empty with filters_set_ false: accept all
  bool filters_set_ = false;

  // Reopen state. retry_at_ == TimePoint::min() means "at the next process()".
  bool want_open_ = false;
  TimePoint retry_at_ = TimePoint::min();
  std::chrono::milliseconds backoff_{0};
  TimePoint next_link_check_ = TimePoint::min();

  // Drops are cumulative per socket; a new socket starts at zero again.
  uint64_t drops_closed_sockets_ = 0;
  uint64_t drops_this_socket_ = 0;
  // The drop count of the last frame read (its SO_RXQ_OVFL), and drops not
  // yet marked on a delivered frame (Frame::dropped_before). RX thread.
  uint32_t marked_drops_ = 0;
  uint64_t unmarked_drops_ = 0;

  // Set on the hot path, logged by process(): receive()/send() stay silent.
  int down_errno_to_log_ = 0;

  // Receive buffers, prepared once.
  std::array<can_frame, kBatch> rx_frames_{};
  std::array<iovec, kBatch> rx_iov_{};
  std::array<mmsghdr, kBatch> rx_msgs_{};
  struct alignas(cmsghdr) Control {
    unsigned char bytes[kControlBytes];
  };
  std::array<Control, kBatch> rx_control_{};

  // Double buffer so a span from take_events() survives later pushes.
  std::array<std::array<BusEvent, kEventCapacity>, 2> events_{};
  std::size_t events_active_ = 0;
  std::size_t events_count_ = 0;

  Counter rx_count_, tx_count_, tx_dropped_, overflow_, error_frames_, events_dropped_, reopens_;
};

}  // namespace cobridge::can
