#include "tcp_server.hpp"

#include "write_record.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <ctime>

namespace cobridge::modbus {
namespace {

constexpr std::uint64_t kListenTag = ~std::uint64_t{0};
constexpr std::uint64_t kWakeTag = ~std::uint64_t{0} - 1;
// At most this many recv() per connection per wake-up: a client that
// pipelines requests at full speed still leaves the loop to the others.
constexpr int kReadsPerWake = 8;
// Idle connections are looked for at this period (the timeout's resolution).
constexpr int kSweepPeriodMs = 200;
constexpr std::uint64_t kAcceptBackoffMinNs = 100'000'000u;  // 100 ms
constexpr std::uint64_t kAcceptBackoffMaxNs = 1'000'000'000u;  // 1 s

std::uint64_t clock_ns(clockid_t id) noexcept {
  timespec ts{};
  clock_gettime(id, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000u + static_cast<std::uint64_t>(ts.tv_nsec);
}

ReadTime now_times() noexcept { return {clock_ns(CLOCK_REALTIME), clock_ns(CLOCK_MONOTONIC)}; }

std::uint64_t tag(std::uint32_t index, std::uint32_t generation) noexcept {
  return (static_cast<std::uint64_t>(generation) << 32) | index;
}

std::string address_text(const sockaddr_storage& ss) {
  std::array<char, INET6_ADDRSTRLEN> buf{};
  std::uint16_t port = 0;
  if (ss.ss_family == AF_INET) {
    sockaddr_in in{};
    std::memcpy(&in, &ss, sizeof in);
    inet_ntop(AF_INET, &in.sin_addr, buf.data(), buf.size());
    port = ntohs(in.sin_port);
    return std::string(buf.data()) + ":" + std::to_string(port);
  }
  sockaddr_in6 in6{};
  std::memcpy(&in6, &ss, sizeof in6);
  inet_ntop(AF_INET6, &in6.sin6_addr, buf.data(), buf.size());
  port = ntohs(in6.sin6_port);
  return "[" + std::string(buf.data()) + "]:" + std::to_string(port);
}

// An IPv4 or IPv6 address and port as a socket address; false when `bind`
// is neither.
bool parse_bind_address(const std::string& bind, std::uint16_t port, sockaddr_storage& ss, socklen_t& len) {
  sockaddr_in in{};
  sockaddr_in6 in6{};
  if (inet_pton(AF_INET, bind.c_str(), &in.sin_addr) == 1) {
    in.sin_family = AF_INET;
    in.sin_port = htons(port);
    std::memcpy(&ss, &in, sizeof in);
    len = sizeof in;
    return true;
  }
  if (inet_pton(AF_INET6, bind.c_str(), &in6.sin6_addr) == 1) {
    in6.sin6_family = AF_INET6;
    in6.sin6_port = htons(port);
    std::memcpy(&ss, &in6, sizeof in6);
    len = sizeof in6;
    return true;
  }
  return false;
}

}  // namespace

TcpServer::TcpServer(const ServerConfig& config, const RegisterImage& image, LogFn log, WriteTarget* writes)
    : config_(config), policy_(config.policy()), image_(image), log_(std::move(log)), writes_(writes) {
  read_only_ = policy_;
  read_only_.writes_enabled = false;  // a client outside write_allow: writes answer 0x01 as when disabled
}

TcpServer::~TcpServer() { stop(); }

std::string TcpServer::endpoint() const {
  const bool v6 = config_.bind.find(':') != std::string::npos;
  return (v6 ? "[" + config_.bind + "]" : config_.bind) + ":" + std::to_string(bound_port_);
}

plugin::Error TcpServer::start() {
  sockaddr_storage ss{};
  socklen_t len = 0;
  if (!parse_bind_address(config_.bind, config_.port, ss, len)) {
    return {std::make_error_code(std::errc::invalid_argument),
            "bind address '" + config_.bind + "' is not an IP address"};
  }
  if (plugin::Error e = open_sockets(ss, len)) {
    stop();
    return e;
  }
  // Every connection's buffers are allocated here, once.
  conns_ = std::vector<Connection>(config_.max_clients);
  free_.clear();
  free_.reserve(config_.max_clients);
  for (std::uint32_t i = config_.max_clients; i > 0; --i) free_.push_back(i - 1);
  open_ = 0;
  connected_.store(0, std::memory_order_relaxed);
  try {
    thread_ = std::thread([this] { run(); });
  } catch (const std::system_error& e) {
    stop();
    return {e.code(), std::string("cannot start the server thread: ") + e.what()};
  }
  return {};
}

// The listening socket, bound to `ss`, and the epoll set with the wake-up
// eventfd. A failure has the errno as its code and names the step and the
// address in its message; the caller stops what was opened.
plugin::Error TcpServer::open_sockets(const sockaddr_storage& ss, socklen_t len) {
  const auto fail = [&](const char* what) {
    const int e = errno;
    return plugin::Error(std::error_code(e, std::system_category()),
                         std::string(what) + " " + config_.bind + ":" + std::to_string(config_.port) + ": " +
                             std::strerror(e));
  };
  listen_fd_ = ::socket(ss.ss_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0) return fail("socket");
  const int one = 1;
  ::setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (::bind(listen_fd_, reinterpret_cast<const sockaddr*>(&ss), len) != 0) return fail("bind");
  if (::listen(listen_fd_, 128) != 0) return fail("listen");
  sockaddr_storage bound{};
  socklen_t bound_len = sizeof bound;
  if (::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&bound), &bound_len) == 0) {
    bound_port_ = bound.ss_family == AF_INET ? ntohs(reinterpret_cast<const sockaddr_in*>(&bound)->sin_port)
                                             : ntohs(reinterpret_cast<const sockaddr_in6*>(&bound)->sin6_port);
  }
  epoll_fd_ = ::epoll_create1(EPOLL_CLOEXEC);
  if (epoll_fd_ < 0) return fail("epoll_create1 for");
  wake_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_fd_ < 0) return fail("eventfd for");
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.u64 = kListenTag;
  if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, listen_fd_, &ev) != 0) return fail("epoll_ctl for");
  ev.data.u64 = kWakeTag;
  if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, wake_fd_, &ev) != 0) return fail("epoll_ctl for");
  return {};
}

void TcpServer::stop() noexcept {
  if (thread_.joinable()) {
    const std::uint64_t one = 1;
    [[maybe_unused]] const auto n = ::write(wake_fd_, &one, sizeof one);
    thread_.join();
  }
  for (std::uint32_t i = 0; i < conns_.size(); ++i) {
    if (conns_[i].fd >= 0) close_connection(i);
  }
  for (int* fd : {&listen_fd_, &epoll_fd_, &wake_fd_}) {
    if (*fd >= 0) ::close(*fd);
    *fd = -1;
  }
}

ServerStats TcpServer::stats() const noexcept {
  const auto r = std::memory_order_relaxed;
  return {accepted_.load(r),       refused_allow_.load(r), refused_full_.load(r), closed_idle_.load(r),
          closed_protocol_.load(r), closed_silent_.load(r), evicted_.load(r),      accept_pauses_.load(r),
          requests_.load(r),        exceptions_.load(r),   connected_.load(r)};
}

void TcpServer::run() noexcept {
  std::array<epoll_event, 64> events{};
  std::uint64_t next_sweep = clock_ns(CLOCK_MONOTONIC);
  for (;;) {
    const int n = ::epoll_wait(epoll_fd_, events.data(), static_cast<int>(events.size()),
                               wait_ms(clock_ns(CLOCK_MONOTONIC)));
    if (n < 0 && errno != EINTR) {
      log_(COBRIDGE_LOG_ERROR, std::string("epoll_wait: ") + std::strerror(errno) + "; server stopped");
      return;
    }
    for (int i = 0; i < n; ++i) {
      const epoll_event& e = events[static_cast<std::size_t>(i)];
      if (e.data.u64 == kWakeTag) return;
      if (e.data.u64 == kListenTag) {
        accept_all();
        continue;
      }
      const auto index = static_cast<std::uint32_t>(e.data.u64 & 0xFFFF'FFFFu);
      const auto generation = static_cast<std::uint32_t>(e.data.u64 >> 32);
      // A connection closed earlier in this batch may have been reused.
      if (index >= conns_.size() || conns_[index].fd < 0 || conns_[index].generation != generation) continue;
      on_event(index, e.events);
    }
    const std::uint64_t now = clock_ns(CLOCK_MONOTONIC);
    if (accept_paused_until_ != 0 && now >= accept_paused_until_) resume_accept(now);
    if (sweeping() && now >= next_sweep) {
      sweep_idle(now);
      next_sweep = now + static_cast<std::uint64_t>(kSweepPeriodMs) * 1'000'000u;
    }
  }
}

bool TcpServer::sweeping() const noexcept {
  return open_ > 0 && (config_.idle_timeout_s > 0 || config_.first_request_timeout_ms > 0);
}

int TcpServer::wait_ms(std::uint64_t now_ns) const noexcept {
  int timeout = sweeping() ? kSweepPeriodMs : -1;
  if (accept_paused_until_ != 0) {
    const auto left = static_cast<int>((accept_paused_until_ > now_ns ? accept_paused_until_ - now_ns : 0) / 1'000'000u) + 1;
    timeout = timeout < 0 ? left : std::min(timeout, left);
  }
  return timeout;
}

// Out of descriptors: the listen socket is level-triggered, so every
// epoll_wait would return at once for the client still in the backlog (100 %
// CPU). Take it out of the epoll set for a while, doubling up to 1 s, and say
// so once per episode.
void TcpServer::pause_accept(int err, std::uint64_t now_ns) noexcept {
  accept_backoff_ns_ = accept_backoff_ns_ == 0 ? kAcceptBackoffMinNs : std::min(2 * accept_backoff_ns_, kAcceptBackoffMaxNs);
  accept_paused_until_ = now_ns + accept_backoff_ns_;
  (void)::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, listen_fd_, nullptr);
  if (accept_pauses_.fetch_add(1, std::memory_order_relaxed) == 0 || accept_backoff_ns_ == kAcceptBackoffMinNs)
    log_(COBRIDGE_LOG_WARN, std::string("accept: ") + std::strerror(err) + "; not accepting for " +
                                std::to_string(accept_backoff_ns_ / 1'000'000u) + " ms (" +
                                std::to_string(open_) + " connections open)");
}

void TcpServer::resume_accept(std::uint64_t now_ns) noexcept {
  (void)now_ns;
  accept_paused_until_ = 0;
  epoll_event ev{};
  ev.events = EPOLLIN;
  ev.data.u64 = kListenTag;
  (void)::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, listen_fd_, &ev);
  accept_all();
}

void TcpServer::accept_all() noexcept {
  for (;;) {
    sockaddr_storage ss{};
    socklen_t len = sizeof ss;
    const int fd = ::accept4(listen_fd_, reinterpret_cast<sockaddr*>(&ss), &len, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) {
      const int err = errno;
      if (err == EINTR || err == ECONNABORTED) continue;
      if (err == EAGAIN || err == EWOULDBLOCK) {
        accept_backoff_ns_ = 0;  // the episode is over
        return;
      }
      // EMFILE, ENFILE, ENOBUFS, ENOMEM: the client stays in the backlog.
      pause_accept(err, clock_ns(CLOCK_MONOTONIC));
      return;
    }
    if (!config_.allow.contains(reinterpret_cast<const sockaddr*>(&ss))) {
      refused_allow_.fetch_add(1, std::memory_order_relaxed);
      log_(COBRIDGE_LOG_DEBUG, "refused " + address_text(ss) + ": not in the allow list");
      ::close(fd);
      continue;
    }
    if (free_.empty() && !evict_oldest_idle()) {
      refused_full_.fetch_add(1, std::memory_order_relaxed);
      log_(COBRIDGE_LOG_DEBUG, "refused " + address_text(ss) + ": max_clients reached");
      ::close(fd);
      continue;
    }
    const int one = 1;
    ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    const std::uint32_t index = free_.back();
    free_.pop_back();
    Connection& c = conns_[index];
    c.fd = fd;
    c.reading = true;
    c.in_len = 0;
    c.out_head = 0;
    c.out_len = 0;
    c.last_rx_ns = clock_ns(CLOCK_MONOTONIC);
    c.accepted_ns = c.last_rx_ns;
    c.closing = false;
    c.requested = false;
    c.events = EPOLLIN;
    epoll_event ev{};
    ev.events = c.events;
    ev.data.u64 = tag(index, c.generation);
    if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, fd, &ev) != 0) {
      ::close(fd);
      c.fd = -1;
      free_.push_back(index);
      continue;
    }
    ++open_;
    connected_.store(open_, std::memory_order_relaxed);
    accepted_.fetch_add(1, std::memory_order_relaxed);
    c.peer = address_text(ss);
    c.may_write = config_.write_allow.allows_writer(reinterpret_cast<const sockaddr*>(&ss));
    log_(COBRIDGE_LOG_DEBUG, "client " + c.peer + " connected" + read_only_note(c, ss));
  }
}

// Why a connected client's writes will be refused, for the log ("" when
// they will not be).
std::string TcpServer::read_only_note(const Connection& c, const sockaddr_storage& ss) const {
  if (!policy_.writes_enabled || c.may_write) return {};
  return IpAllowList::is_loopback(reinterpret_cast<const sockaddr*>(&ss))
             ? ", read-only: a loopback client writes only when write_allow lists it"
             : ", read-only: not in write_allow";
}

void TcpServer::close_connection(std::uint32_t index) noexcept {
  Connection& c = conns_[index];
  if (c.fd < 0) return;
  if (epoll_fd_ >= 0) ::epoll_ctl(epoll_fd_, EPOLL_CTL_DEL, c.fd, nullptr);
  ::close(c.fd);
  c.fd = -1;
  // Skip the two values that could collide with the special tags.
  c.generation = c.generation >= 0xFFFF'FFF0u ? 1 : c.generation + 1;
  free_.push_back(index);
  --open_;
  connected_.store(open_, std::memory_order_relaxed);
}

void TcpServer::on_event(std::uint32_t index, std::uint32_t events) noexcept {
  Connection& c = conns_[index];
  if ((events & EPOLLOUT) != 0) {
    if (!flush(c) || (c.closing && c.out_head >= c.out_len)) {
      close_connection(index);  // a closing connection goes once its answers are out
      return;
    }
    // Room again in the output buffer: answer what is already buffered.
    if (!c.reading && c.out_len - c.out_head + kMaxFrameSize <= kOutBuffer) {
      c.reading = true;
      if (!process(c)) {
        close_connection(index);
        return;
      }
    }
  }
  if ((events & (EPOLLIN | EPOLLERR | EPOLLHUP)) != 0 && c.reading) {
    read_some(c, index);
    if (c.fd < 0) return;
  } else if ((events & (EPOLLERR | EPOLLHUP)) != 0 && !c.reading) {
    close_connection(index);
    return;
  }
  update_interest(c, index);
}

void TcpServer::read_some(Connection& c, std::uint32_t index) noexcept {
  for (int i = 0; i < kReadsPerWake && c.reading; ++i) {
    const std::size_t space = kMaxFrameSize - c.in_len;
    const ssize_t r = ::recv(c.fd, c.in + c.in_len, space, 0);
    if (r > 0) {
      c.in_len += static_cast<std::size_t>(r);
      c.last_rx_ns = clock_ns(CLOCK_MONOTONIC);
      if (!process(c)) {
        close_connection(index);
        return;
      }
      if (static_cast<std::size_t>(r) < space) return;  // drained the socket
      continue;
    }
    if (r < 0 && errno == EINTR) continue;
    if (r < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
    close_connection(index);  // EOF (a partial frame dies with it) or an error
    return;
  }
}

bool TcpServer::process(Connection& c) noexcept {
  std::size_t off = 0;
  const ReadTime now = now_times();
  bool ok = true;
  for (;;) {
    const FrameCheck fc = check_frame(std::span<const std::uint8_t>(c.in + off, c.in_len - off));
    if (fc.state == FrameState::kInvalid) {
      closed_protocol_.fetch_add(1, std::memory_order_relaxed);
      ok = false;
      break;
    }
    c.requested = true;
    if (fc.state == FrameState::kIncomplete) break;
    if (c.out_head > 0) {  // keep the pending output at the front
      std::memmove(c.out, c.out + c.out_head, c.out_len - c.out_head);
      c.out_len -= c.out_head;
      c.out_head = 0;
    }
    if (kOutBuffer - c.out_len < kMaxFrameSize) {
      c.reading = false;  // the client does not read its answers: stop reading its requests
      break;
    }
    const std::size_t n = handle_request(std::span<const std::uint8_t>(c.in + off, fc.length), image_,
                                         c.may_write ? policy_ : read_only_, now,
                                         std::span<std::uint8_t>(c.out + c.out_len, kOutBuffer - c.out_len), writes_);
    off += fc.length;
    if (n == 0) {
      closed_protocol_.fetch_add(1, std::memory_order_relaxed);
      ok = false;
      break;
    }
    requests_.fetch_add(1, std::memory_order_relaxed);
    if ((c.out[c.out_len + 7] & 0x80u) != 0) exceptions_.fetch_add(1, std::memory_order_relaxed);
    if (auto w = describe_write(c.peer, std::span<const std::uint8_t>(c.in + off - fc.length, fc.length),
                                std::span<const std::uint8_t>(c.out + c.out_len, n)))
      log_(COBRIDGE_LOG_INFO, *w);
    c.out_len += n;
  }
  if (!ok) {
    // Every complete request before the bad one is answered, then the
    // connection closes (MBAP framing is lost after an invalid header).
    c.closing = true;
    c.reading = false;
    return flush(c) && c.out_head < c.out_len;
  }
  if (off > 0) {
    std::memmove(c.in, c.in + off, c.in_len - off);
    c.in_len -= off;
  }
  return flush(c);
}

bool TcpServer::flush(Connection& c) noexcept {
  while (c.out_head < c.out_len) {
    const ssize_t r = ::send(c.fd, c.out + c.out_head, c.out_len - c.out_head, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (r > 0) {
      c.out_head += static_cast<std::size_t>(r);
      continue;
    }
    if (r < 0 && errno == EINTR) continue;
    if (r < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return true;
    return false;
  }
  c.out_head = 0;
  c.out_len = 0;
  return true;
}

void TcpServer::update_interest(Connection& c, std::uint32_t index) noexcept {
  std::uint32_t want = 0;
  if (c.reading) want |= EPOLLIN;
  if (c.out_head < c.out_len) want |= EPOLLOUT;
  if (want == c.events) return;
  epoll_event ev{};
  ev.events = want;
  ev.data.u64 = tag(index, c.generation);
  if (::epoll_ctl(epoll_fd_, EPOLL_CTL_MOD, c.fd, &ev) == 0) c.events = want;
}

void TcpServer::sweep_idle(std::uint64_t now_ns) noexcept {
  const std::uint64_t limit = static_cast<std::uint64_t>(config_.idle_timeout_s) * 1'000'000'000u;
  for (std::uint32_t i = 0; i < conns_.size(); ++i) {
    Connection& c = conns_[i];
    if (c.fd < 0) continue;
    const std::uint64_t first_limit = static_cast<std::uint64_t>(config_.first_request_timeout_ms) * 1'000'000u;
    if (!c.requested && first_limit > 0 && now_ns - c.accepted_ns >= first_limit) {
      closed_silent_.fetch_add(1, std::memory_order_relaxed);
      log_(COBRIDGE_LOG_DEBUG, "closing a connection that sent no request within " +
                                   std::to_string(config_.first_request_timeout_ms) + " ms");
      close_connection(i);
    } else if (limit > 0 && now_ns - c.last_rx_ns >= limit) {
      closed_idle_.fetch_add(1, std::memory_order_relaxed);
      log_(COBRIDGE_LOG_DEBUG, "closing a connection idle for " + std::to_string(config_.idle_timeout_s) + " s");
      close_connection(i);
    }
  }
}

// Full: the connection silent the longest, with no answer still to send,
// makes room for the new client (a SCADA that reconnects must get in even if
// dead connections hold every slot). Logged at most once a second.
bool TcpServer::evict_oldest_idle() noexcept {
  std::uint32_t oldest = 0;
  bool found = false;
  for (std::uint32_t i = 0; i < conns_.size(); ++i) {
    const Connection& c = conns_[i];
    if (c.fd < 0 || c.out_head < c.out_len) continue;
    if (!found || c.last_rx_ns < conns_[oldest].last_rx_ns) oldest = i;
    found = true;
  }
  if (!found) return false;
  const std::uint64_t now = clock_ns(CLOCK_MONOTONIC);
  const std::uint64_t silent_ms = (now - conns_[oldest].last_rx_ns) / 1'000'000u;
  evicted_.fetch_add(1, std::memory_order_relaxed);
  if (now - last_evict_log_ns_ >= 1'000'000'000u) {
    last_evict_log_ns_ = now;
    log_(COBRIDGE_LOG_WARN, "max_clients reached: closed the connection idle longest (" + std::to_string(silent_ms) +
                                " ms) for a new client");
  }
  close_connection(oldest);
  return true;
}

}  // namespace cobridge::modbus
