#include "can/socketcan_channel.hpp"

#include "sys/logging.hpp"

#include <errno.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <linux/sock_diag.h>
#include <net/if.h>
#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <memory>

namespace cobridge::can {
namespace {

// The "can" logger of sys/logging (the daemon's sink: journal or console).
// Off the hot path only.
std::shared_ptr<spdlog::logger> logger() noexcept {
  try {
    return sys::logger("can");
  } catch (...) {
    // Logging is unavailable (out of memory): log nothing.
    return spdlog::get("can");
  }
}

// The receive queue is what carries the hot path over a scheduling stall
// (a loaded host, a slow virtual CPU): at 1 Mbit/s a full bus fills the
// kernel's default (about 200 KiB, some 400 frames) in 50 ms. SO_RCVBUF is
// capped by net.core.rmem_max; SO_RCVBUFFORCE is not, but needs
// CAP_NET_ADMIN. The size the kernel granted is checked and a shortfall
// logged once per socket, with the setting that lifts it.
// Binding to an interface that went down in between leaves ENETDOWN pending
// on the socket (net/can/raw.c); reading SO_ERROR also clears it.
int take_socket_error(int fd) noexcept {
  int so_error = 0;
  socklen_t so_len = sizeof so_error;
  if (::getsockopt(fd, SOL_SOCKET, SO_ERROR, &so_error, &so_len) != 0) return 0;
  return so_error;
}

int set_receive_buffer(int fd, int bytes, const std::string& name) {
  if (::setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &bytes, sizeof bytes) == 0) return 0;
  if (::setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &bytes, sizeof bytes) < 0) return errno;
  int granted = 0;
  socklen_t len = sizeof granted;
  // Linux reports twice the size asked for (bookkeeping overhead included).
  if (::getsockopt(fd, SOL_SOCKET, SO_RCVBUF, &granted, &len) == 0 && granted / 2 < bytes) {
    if (auto log = logger()) log->warn("{}: receive queue {} KiB, not the {} KiB asked for (raise net.core.rmem_max to at least {}, "
                   "or grant CAP_NET_ADMIN): a stalled reader loses frames sooner",
                   name, granted / 2 / 1024, bytes / 1024, bytes);
  }
  return 0;
}

std::string errno_text(int err) {
  return std::error_code(err, std::system_category()).message();
}

// An open / filter failure of interface `name` (see the header).
Error make_error(int err, const std::string& name, std::string message, Errc kind = Errc::kUnavailable) {
  return Error(kind, std::move(message), name, std::error_code(err, std::system_category()));
}

// errno values that mean the interface is gone or down rather than busy.
bool is_link_errno(int err) noexcept { return err == ENETDOWN || err == ENODEV || err == ENXIO; }

bool fill_ifreq(ifreq& ifr, const std::string& name) noexcept {
  std::memset(&ifr, 0, sizeof ifr);
  if (name.empty() || name.size() >= sizeof ifr.ifr_name) return false;
  std::memcpy(ifr.ifr_name, name.data(), name.size());
  return true;
}

// IFF_UP of `name`, or the errno of the query (ENODEV when it vanished).
int query_interface_up(int fd, const std::string& name, bool& up) noexcept {
  ifreq ifr{};
  if (!fill_ifreq(ifr, name)) return ENODEV;
  if (::ioctl(fd, SIOCGIFFLAGS, &ifr) < 0) return errno;
  up = (ifr.ifr_flags & IFF_UP) != 0;
  return 0;
}

// Walks the control messages of one received message. The libc CMSG_* macros
// are written with C casts, which this project's warnings reject.
template <typename Fn>
void for_each_cmsg(const msghdr& msg, Fn&& fn) noexcept {
  const auto* base = static_cast<const unsigned char*>(msg.msg_control);
  std::size_t off = 0;
  const std::size_t total = msg.msg_controllen;
  const std::size_t align = sizeof(std::size_t);
  const std::size_t header = (sizeof(cmsghdr) + align - 1) & ~(align - 1);
  while (off + sizeof(cmsghdr) <= total) {
    cmsghdr h;
    std::memcpy(&h, base + off, sizeof h);
    if (h.cmsg_len < sizeof(cmsghdr) || off + h.cmsg_len > total) return;
    fn(h.cmsg_level, h.cmsg_type, base + off + header, h.cmsg_len - header);
    off += (h.cmsg_len + align - 1) & ~(align - 1);
  }
}

}  // namespace

can_filter to_linux(const Filter& filter) noexcept {
  can_filter f{};
  // CAN_EFF_FLAG in the mask makes the frame format part of the match, so an
  // 11-bit filter never accepts a 29-bit frame with the same low bits.
  if (filter.extended) {
    f.can_id = (filter.id & CAN_EFF_MASK) | CAN_EFF_FLAG;
    f.can_mask = (filter.mask & CAN_EFF_MASK) | CAN_EFF_FLAG;
  } else {
    f.can_id = filter.id & CAN_SFF_MASK;
    f.can_mask = (filter.mask & CAN_SFF_MASK) | CAN_EFF_FLAG;
  }
  return f;
}

can_frame to_linux(const Frame& frame) noexcept {
  can_frame cf{};
  if (frame.is_error()) {
    cf.can_id = (frame.id & CAN_ERR_MASK) | CAN_ERR_FLAG;
  } else if (frame.is_extended()) {
    cf.can_id = (frame.id & CAN_EFF_MASK) | CAN_EFF_FLAG;
  } else {
    cf.can_id = frame.id & CAN_SFF_MASK;
  }
  if (frame.is_rtr()) cf.can_id |= CAN_RTR_FLAG;
  cf.len = std::min<uint8_t>(frame.len, CAN_MAX_DLEN);
  std::memcpy(cf.data, frame.data.data(), sizeof cf.data);
  return cf;
}

Frame from_linux(const can_frame& cf, int64_t timestamp_ns) noexcept {
  Frame f;
  if ((cf.can_id & CAN_ERR_FLAG) != 0) {
    f.id = cf.can_id & CAN_ERR_MASK;
    f.flags = Frame::kFlagError;
  } else if ((cf.can_id & CAN_EFF_FLAG) != 0) {
    f.id = cf.can_id & CAN_EFF_MASK;
    f.flags = Frame::kFlagExtended;
  } else {
    f.id = cf.can_id & CAN_SFF_MASK;
  }
  if ((cf.can_id & CAN_RTR_FLAG) != 0 && !f.is_error()) f.flags |= Frame::kFlagRtr;
  f.len = std::min<uint8_t>(cf.len, CAN_MAX_DLEN);
  std::memcpy(f.data.data(), cf.data, f.data.size());
  f.timestamp_ns = timestamp_ns;
  return f;
}

SocketCanChannel::SocketCanChannel(SocketCanConfig config) : config_(std::move(config)) {
  for (std::size_t i = 0; i < kBatch; ++i) {
    rx_iov_[i].iov_base = &rx_frames_[i];
    rx_iov_[i].iov_len = sizeof(can_frame);
    msghdr& h = rx_msgs_[i].msg_hdr;
    h.msg_name = nullptr;
    h.msg_namelen = 0;
    h.msg_iov = &rx_iov_[i];
    h.msg_iovlen = 1;
    h.msg_control = rx_control_[i].bytes;
    h.msg_controllen = kControlBytes;
  }
}

SocketCanChannel::~SocketCanChannel() { close(); }

Error SocketCanChannel::open() {
  close();
  want_open_ = true;
  backoff_ = config_.reopen_backoff_min;
  OpenOutcome o = open_socket();
  if (o.error) {
    want_open_ = false;
    return std::move(o.error);  // the caller reports it, once, with its own context
  }
  if (o.interface_down) {
    // Not an error: the daemon may start before the link is configured.
    push_interface_event(BusEventKind::InterfaceDown);
    retry_at_ = TimePoint::min();
    if (auto l = logger(); l && o.missing) {
      l->warn("{}: no such interface (adapter not plugged in?); will open it when it appears", config_.interface);
    } else if (l) {
      l->warn("{}: interface is down; will open it when it comes up", config_.interface);
    }
    return {};
  }
  if (auto l = logger()) l->info("{}: opened (CAN_RAW, fd {})", config_.interface, fd_);
  return {};
}

// The error filter, the frame filters, timestamps, drop counts and the
// receive buffer. Returns 0, or the errno and in `what` the step that failed.
int SocketCanChannel::set_socket_options(int fd, const char*& what) const {
  const can_err_mask_t err_mask = config_.error_mask & CAN_ERR_MASK;
  what = "CAN_RAW_ERR_FILTER failed";
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask) < 0) return errno;
  if (filters_set_) {
    const void* data = filters_.empty() ? nullptr : filters_.data();
    const auto len = static_cast<socklen_t>(filters_.size() * sizeof(can_filter));
    what = "CAN_RAW_FILTER failed";
    if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, data, len) < 0) return errno;
  }
  const int on = 1;
  what = "SO_TIMESTAMPNS failed";
  if (::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) < 0) return errno;
  what = "SO_RXQ_OVFL failed";
  if (::setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on) < 0) return errno;
  what = "SO_RCVBUF failed";
  if (config_.receive_buffer_bytes > 0) return set_receive_buffer(fd, config_.receive_buffer_bytes, config_.interface);
  return 0;
}

SocketCanChannel::OpenOutcome SocketCanChannel::open_socket() {
  const std::string& name = config_.interface;
  ifreq ifr{};
  if (!fill_ifreq(ifr, name))
    return {make_error(ENODEV, name, "CAN interface name is empty or longer than IFNAMSIZ-1",
                       Errc::kInvalidArgument), false};

  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    const int err = errno;
    return {make_error(err, name, "socket(PF_CAN, SOCK_RAW, CAN_RAW) failed: " + errno_text(err) +
                                      " (is the can-raw module loaded?)"),
            false};
  }
  auto fail = [&](int err, const std::string& what) {
    ::close(fd);
    return OpenOutcome{make_error(err, name, what + ": " + errno_text(err)), false};
  };
  auto down = [&]() {
    ::close(fd);
    return OpenOutcome{{}, true};
  };

  if (::ioctl(fd, SIOCGIFINDEX, &ifr) < 0) {
    const int err = errno;
    if (err == ENODEV && config_.wait_for_interface) {
      ::close(fd);
      return OpenOutcome{{}, true, true};
    }
    if (err == ENODEV) return fail(err, "no such network interface");
    return fail(err, "SIOCGIFINDEX failed");
  }
  const int ifindex = ifr.ifr_ifindex;

  bool up = false;
  if (const int err = query_interface_up(fd, name, up); err != 0) return fail(err, "SIOCGIFFLAGS failed");

  const char* what = nullptr;
  if (const int err = set_socket_options(fd, what); err != 0) return fail(err, what);

  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifindex;
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) < 0) {
    const int err = errno;
    if (err == ENODEV) return fail(err, "not a CAN interface (bind)");
    return fail(err, "bind failed");
  }
  if (!up) return down();
  if (const int so_error = take_socket_error(fd); so_error != 0) {
    if (is_link_errno(so_error)) return down();
    return fail(so_error, "socket error after bind");
  }

  fd_ = fd;
  drops_this_socket_ = 0;
  marked_drops_ = 0;  // a new socket's kernel count starts at 0
  unmarked_drops_ = 0;
  return {};
}

void SocketCanChannel::close() noexcept {
  want_open_ = false;
  if (fd_ < 0) return;
  close_socket();
}

// The socket's drop count joins the closed sockets' before it goes.
void SocketCanChannel::close_socket() noexcept {
  refresh_overflow_from_meminfo();
  drops_closed_sockets_ += drops_this_socket_;
  drops_this_socket_ = 0;
  ::close(fd_);
  fd_ = -1;
}

Error SocketCanChannel::set_filters(std::span<const Filter> filters) {
  filters_.clear();
  filters_.reserve(filters.size());
  for (const Filter& f : filters) filters_.push_back(to_linux(f));
  filters_set_ = true;
  if (fd_ >= 0 && !apply_filters()) {
    const int err = errno;
    return make_error(err, config_.interface, "CAN_RAW_FILTER failed: " + errno_text(err));
  }
  return {};
}

bool SocketCanChannel::apply_filters() noexcept {
  if (!filters_set_) return true;
  const void* data = filters_.empty() ? nullptr : filters_.data();
  const auto len = static_cast<socklen_t>(filters_.size() * sizeof(can_filter));
  return ::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, data, len) == 0;
}

std::size_t SocketCanChannel::receive(std::span<Frame> out) noexcept {
  std::size_t k = 0;
  while (fd_ >= 0 && k < out.size()) {
    const std::size_t want = std::min(kBatch, out.size() - k);
    for (std::size_t i = 0; i < want; ++i) {
      rx_msgs_[i].msg_hdr.msg_controllen = kControlBytes;
      rx_msgs_[i].msg_hdr.msg_flags = 0;
      rx_msgs_[i].msg_len = 0;
    }
    const int got = ::recvmmsg(fd_, rx_msgs_.data(), static_cast<unsigned>(want), MSG_DONTWAIT, nullptr);
    if (got < 0) {
      const int err = errno;
      if (err == EINTR) continue;
      if (is_link_errno(err)) went_down(err);
      break;  // EAGAIN: drained. Anything else: try again on the next call.
    }
    const auto n = static_cast<std::size_t>(got);
    for (std::size_t i = 0; i < n; ++i) {
      if (rx_msgs_[i].msg_len != sizeof(can_frame)) continue;  // not a classic frame
      int64_t ts = 0;
      uint32_t drops_total = 0;
      for_each_cmsg(rx_msgs_[i].msg_hdr, [&](int level, int type, const unsigned char* data, std::size_t len) {
        if (level != SOL_SOCKET) return;
        if (type == SCM_TIMESTAMPNS && len >= sizeof(timespec)) {
          timespec t{};
          std::memcpy(&t, data, sizeof t);
          ts = static_cast<int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
        } else if (type == SO_RXQ_OVFL && len >= sizeof(uint32_t)) {
          std::memcpy(&drops_total, data, sizeof drops_total);
          note_overflow_total(drops_total);
        }
      });
      Frame f = from_linux(rx_frames_[i], ts);
      mark_drops_before(f, drops_total);
      if (f.is_error()) {
        std::array<BusEvent, kMaxEventsPerErrorFrame> ev{};
        const std::size_t m = decode_error_frame(f, ev);
        for (std::size_t j = 0; j < m; ++j) push_event(ev[j]);
        error_frames_.add(1);
        if (!config_.deliver_error_frames) continue;
      }
      out[k++] = f;
    }
    if (n < want) break;  // the socket queue is empty
  }
  rx_count_.add(k);
  return k;
}

bool SocketCanChannel::send(const Frame& frame) noexcept {
  if (fd_ < 0) {
    tx_dropped_.add(1);
    return false;
  }
  const can_frame cf = to_linux(frame);
  bool have_deadline = false;
  Clock::time_point deadline{};
  for (;;) {
    const ssize_t n = ::send(fd_, &cf, sizeof cf, MSG_DONTWAIT | MSG_NOSIGNAL);
    if (n == static_cast<ssize_t>(sizeof cf)) {
      tx_count_.add(1);
      return true;
    }
    const int err = n < 0 ? errno : EIO;
    if (err == EINTR) continue;
    if (err == EAGAIN || err == EWOULDBLOCK || err == ENOBUFS) {
      if (!have_deadline) {
        deadline = Clock::now() + config_.tx_timeout;
        have_deadline = true;
      }
      if (wait_writable(err, deadline)) continue;
    } else if (is_link_errno(err)) {
      went_down(err);
    }
    tx_dropped_.add(1);
    return false;
  }
}

bool SocketCanChannel::wait_writable(int err, Clock::time_point deadline) noexcept {
  const auto now = Clock::now();
  if (now >= deadline) return false;
  const auto remaining = std::chrono::duration_cast<std::chrono::nanoseconds>(deadline - now);
  timespec ts{};
  if (err == ENOBUFS) {
    // The device queue (qdisc) is full, not the socket buffer: POLLOUT would
    // report ready at once. Pause briefly instead of spinning; a CAN frame
    // takes ~100-250 us on the wire at 500-1000 kbit/s.
    const auto pause = std::min<std::chrono::nanoseconds>(remaining, std::chrono::microseconds(200));
    ts.tv_nsec = static_cast<long>(pause.count());
    ::ppoll(nullptr, 0, &ts, nullptr);
    return true;
  }
  ts.tv_sec = static_cast<time_t>(remaining.count() / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(remaining.count() % 1'000'000'000);
  pollfd p{fd_, POLLOUT, 0};
  const int r = ::ppoll(&p, 1, &ts, nullptr);
  if (r < 0) return errno == EINTR;
  // Ready, or an error the next send() will report.
  return r > 0;
}

void SocketCanChannel::went_down(int err) noexcept {
  if (fd_ < 0) return;
  close_socket();
  down_errno_to_log_ = err;
  push_interface_event(BusEventKind::InterfaceDown);
  retry_at_ = TimePoint::min();
  backoff_ = config_.reopen_backoff_min;
}

void SocketCanChannel::log_pending() noexcept {
  if (down_errno_to_log_ == 0) return;
  const int err = down_errno_to_log_;
  down_errno_to_log_ = 0;
  try {
    if (auto l = logger()) l->warn("{}: interface went down ({}); closed, will reopen", config_.interface, errno_text(err));
  } catch (...) {
  }
}

SocketCanChannel::TimePoint SocketCanChannel::process(TimePoint now) {
  if (fd_ >= 0) {
    if (now >= next_link_check_) {
      next_link_check_ = now + config_.link_check_period;
      // Not per call: process() runs on every wake of the RX thread, and the
      // hot path makes no system call but the read. SO_RXQ_OVFL on the
      // frames still counts drops at once; this catches a quiet tail.
      refresh_overflow_from_meminfo();
      bool up = true;
      int so_error = 0;
      socklen_t so_len = sizeof so_error;
      const int q = query_interface_up(fd_, config_.interface, up);
      if (q != 0 && is_link_errno(q)) {
        went_down(q);
      } else if (q == 0 && !up) {
        went_down(ENETDOWN);
      } else if (::getsockopt(fd_, SOL_SOCKET, SO_ERROR, &so_error, &so_len) == 0 && is_link_errno(so_error)) {
        // A down/up cycle between two receive() calls leaves only this trace;
        // the socket itself would keep working, but reopening is harmless.
        went_down(so_error);
      }
    }
  }
  log_pending();
  if (fd_ >= 0) return next_link_check_;
  if (!want_open_) return TimePoint::max();
  if (now < retry_at_) return retry_at_;

  OpenOutcome o = open_socket();
  if (!o.error && !o.interface_down) {
    reopens_.add(1);
    backoff_ = config_.reopen_backoff_min;
    next_link_check_ = now + config_.link_check_period;
    push_interface_event(BusEventKind::InterfaceReopened);
    if (auto l = logger()) l->info("{}: reopened (fd {})", config_.interface, fd_);
    return next_link_check_;
  }
  if (o.error) {
    if (auto l = logger()) l->debug("{} (retrying in {} ms)", o.error.message, backoff_.count());
  }
  retry_at_ = now + backoff_;
  backoff_ = std::min(backoff_ * 2, config_.reopen_backoff_max);
  return retry_at_;
}

void SocketCanChannel::push_event(const BusEvent& event) noexcept {
  if (events_count_ >= kEventCapacity) {
    events_dropped_.add(1);
    return;
  }
  events_[events_active_][events_count_++] = event;
}

void SocketCanChannel::push_interface_event(BusEventKind kind) noexcept {
  BusEvent e;
  e.kind = kind;
  e.timestamp_ns = frame_clock_ns();
  push_event(e);
}

std::span<const BusEvent> SocketCanChannel::take_events() noexcept {
  const std::span<const BusEvent> taken(events_[events_active_].data(), events_count_);
  events_active_ ^= 1U;
  events_count_ = 0;
  return taken;
}

void SocketCanChannel::note_overflow_total(uint32_t total) noexcept {
  // The kernel's counter is cumulative per socket and may arrive out of
  // order relative to SO_MEMINFO reads, so only ever move forward.
  if (total <= drops_this_socket_) return;
  drops_this_socket_ = total;
  overflow_.set(drops_closed_sockets_ + drops_this_socket_);
}

void SocketCanChannel::mark_drops_before(Frame& f, uint32_t total) noexcept {
  // The kernel stamps each queued frame with the socket's drop count at
  // its arrival (absent while it is 0), so a count above the previous
  // frame's means frames were lost between the two. A frame filtered out
  // below (error frames not delivered) passes its mark on to the next.
  if (total > marked_drops_) {
    unmarked_drops_ += total - marked_drops_;
    marked_drops_ = total;
  }
  if (unmarked_drops_ == 0) return;
  if (!config_.deliver_error_frames && f.is_error()) return;
  f.dropped_before = static_cast<uint16_t>(std::min<uint64_t>(unmarked_drops_, 0xFFFF));
  unmarked_drops_ = 0;
}

void SocketCanChannel::refresh_overflow_from_meminfo() noexcept {
  // SO_RXQ_OVFL only rides on frames that arrive after a drop; SO_MEMINFO
  // reads the same counter (sk_drops) directly, so a quiet socket still
  // reports drops at its tail.
  if (fd_ < 0) return;
  std::array<uint32_t, SK_MEMINFO_VARS> mem{};
  auto len = static_cast<socklen_t>(sizeof mem);
  if (::getsockopt(fd_, SOL_SOCKET, SO_MEMINFO, mem.data(), &len) != 0) return;
  if (static_cast<std::size_t>(len) < (SK_MEMINFO_DROPS + 1) * sizeof(uint32_t)) return;
  note_overflow_total(mem[SK_MEMINFO_DROPS]);
}

ChannelStats SocketCanChannel::stats() const noexcept {
  ChannelStats s;
  s.rx_frames = rx_count_.get();
  s.tx_frames = tx_count_.get();
  s.tx_dropped = tx_dropped_.get();
  s.rx_overflow_drops = overflow_.get();
  s.error_frames = error_frames_.get();
  s.events_dropped = events_dropped_.get();
  s.reopens = reopens_.get();
  return s;
}

}  // namespace cobridge::can
