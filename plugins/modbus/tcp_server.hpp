// TcpServer: the Modbus TCP listener of the Modbus output. One thread runs
// an epoll loop over the listening socket and every client connection; all
// sockets are non-blocking, each connection has its own input buffer (one
// frame, 260 bytes) and output buffer, so a client that trickles its request
// a byte at a time, or never reads its answers, costs the others nothing but
// a wake-up. Frames are cut and validated by request.hpp before anything is
// read from the register image; responses are built there too (libmodbus is
// not used at run time).
//
// Admission: clients outside the allow list, and clients beyond
// max_clients, are accepted and closed at once (the client sees a closed
// connection rather than a hanging connect). Connections silent for
// idle_timeout_s are closed.
//
// Thread contract: start/stop on the control thread; the loop runs on the
// server's own thread, reads the RegisterImage and hands enabled writes to
// the WriteTarget (on that thread). stats() from any
// thread. The log callback is called from the server thread, per connection
// event, never per request.
#pragma once

#include "register_image.hpp"
#include "request.hpp"
#include "server_config.hpp"

#include <sys/socket.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

namespace cobridge::modbus {

struct ServerStats {
  std::uint64_t accepted = 0;
  std::uint64_t refused_allow = 0;    // closed at accept: not in the allow list
  std::uint64_t refused_full = 0;     // closed at accept: max_clients reached
  std::uint64_t closed_idle = 0;      // idle timeout
  std::uint64_t closed_protocol = 0;  // framing error (protocol id, length, PDU size); answered up to it
  std::uint64_t closed_silent = 0;    // no first request within first_request_timeout_ms
  std::uint64_t evicted = 0;          // the oldest idle connection, closed for a new client when full
  std::uint64_t accept_pauses = 0;    // accept() out of descriptors (EMFILE/ENFILE): listening paused
  std::uint64_t requests = 0;         // frames answered
  std::uint64_t exceptions = 0;       // of which exception responses
  std::uint64_t connected = 0;        // connections open now
};

class TcpServer {
 public:
  using LogFn = std::function<void(int level, const std::string& message)>;

  // `writes` may be nullptr (every write then answers 0x02).
  TcpServer(const ServerConfig& config, const RegisterImage& image, LogFn log, WriteTarget* writes = nullptr);
  ~TcpServer();
  TcpServer(const TcpServer&) = delete;
  TcpServer& operator=(const TcpServer&) = delete;

  // Binds, listens and starts the thread. A failure has the errno as its
  // code and names the address in its message.
  [[nodiscard]] plugin::Error start();
  void stop() noexcept;

  // The bound port (useful with port = 0) and "address:port" for logs.
  [[nodiscard]] std::uint16_t port() const noexcept { return bound_port_; }
  [[nodiscard]] std::string endpoint() const;
  [[nodiscard]] ServerStats stats() const noexcept;

 private:
  plugin::Error open_sockets(const sockaddr_storage& ss, socklen_t len);
  static constexpr std::size_t kOutBuffer = 4096;
  struct Connection {
    int fd = -1;
    std::uint32_t generation = 1;
    std::uint32_t events = 0;  // current epoll interest
    bool reading = true;       // false while the output buffer is full
    bool closing = false;      // a framing error: answer what came before it, then close
    bool requested = false;    // at least one complete request seen
    std::uint64_t accepted_ns = 0;
    std::size_t in_len = 0;
    std::size_t out_head = 0;
    std::size_t out_len = 0;
    std::uint64_t last_rx_ns = 0;
    std::string peer;          // "address:port", for the write log
    bool may_write = false;    // in write_allow (writes_enabled is checked per request)
    std::uint8_t in[kMaxFrameSize];
    std::uint8_t out[kOutBuffer];
  };

  void run() noexcept;
  void accept_all() noexcept;
  void on_event(std::uint32_t index, std::uint32_t events) noexcept;
  void read_some(Connection& c, std::uint32_t index) noexcept;
  bool process(Connection& c) noexcept;  // false: connection closed
  bool flush(Connection& c) noexcept;    // false: connection closed
  void update_interest(Connection& c, std::uint32_t index) noexcept;
  [[nodiscard]] std::string read_only_note(const Connection& c, const sockaddr_storage& ss) const;
  void close_connection(std::uint32_t index) noexcept;
  void sweep_idle(std::uint64_t now_ns) noexcept;
  [[nodiscard]] bool sweeping() const noexcept;
  bool evict_oldest_idle() noexcept;
  void pause_accept(int err, std::uint64_t now_ns) noexcept;
  void resume_accept(std::uint64_t now_ns) noexcept;
  [[nodiscard]] int wait_ms(std::uint64_t now_ns) const noexcept;

  ServerConfig config_;
  RequestPolicy policy_;
  RequestPolicy read_only_;  // policy_ without writes: clients outside write_allow
  const RegisterImage& image_;
  LogFn log_;
  WriteTarget* writes_;
  int listen_fd_ = -1;
  int epoll_fd_ = -1;
  int wake_fd_ = -1;
  std::uint16_t bound_port_ = 0;
  std::thread thread_;
  std::vector<Connection> conns_;
  std::vector<std::uint32_t> free_;
  std::size_t open_ = 0;
  std::uint64_t accept_paused_until_ = 0;  // 0: the listen socket is in the epoll set
  std::uint64_t accept_backoff_ns_ = 0;
  std::uint64_t last_evict_log_ns_ = 0;

  std::atomic<std::uint64_t> accepted_{0};
  std::atomic<std::uint64_t> refused_allow_{0};
  std::atomic<std::uint64_t> refused_full_{0};
  std::atomic<std::uint64_t> closed_idle_{0};
  std::atomic<std::uint64_t> closed_protocol_{0};
  std::atomic<std::uint64_t> closed_silent_{0};
  std::atomic<std::uint64_t> evicted_{0};
  std::atomic<std::uint64_t> accept_pauses_{0};
  std::atomic<std::uint64_t> requests_{0};
  std::atomic<std::uint64_t> exceptions_{0};
  std::atomic<std::uint64_t> connected_{0};  // open_, for stats() on other threads
};

}  // namespace cobridge::modbus
