// AsciiServer: the CiA 309-3 ASCII gateway on a Unix
// socket and optionally TCP (127.0.0.1 by default): the command set of
// ascii_request.hpp, one request line -> one answer line, for `cocomm` and
// other 309-3 clients. Every SDO / NMT / LSS request becomes a
// ServiceRequest for the bus of its net (net N = the N-th configured bus),
// queued with the daemon's own work exactly like `cobridge sdo` through the
// control socket; the daemon stays the one master of the bus.
//
// Writes (w, NMT, LSS) are refused with "ERROR: 100" unless
// [ascii_gateway] writes_enabled; each write is logged with the caller (uid
// and pid on the Unix socket, the address on TCP). A connection runs one
// request at a time (later lines wait, in order); "set network / node /
// sdo_timeout" are per connection. No client can hold the daemon up: the
// sockets are non-blocking, a line longer than `max_line` is answered
// "ERROR: 101" and skipped, at most `max_clients` connections, an idle one
// is closed after `idle_timeout`.
//
// Thread: the daemon's main thread, like ControlServer (which drives it):
// add_poll_fds() before poll(), process(now) after. That thread owns every
// connection for its whole life: a request's SDO / NMT / LSS command runs
// on its bus's control thread, which only pushes the result to this
// server's ServiceReplies; the answer is formatted and written here. While
// a command runs its client's socket is not read (later lines wait there,
// in order).
#pragma once

#include "base/error.hpp"
#include "canopen/clock.hpp"
#include "config/service_access.hpp"
#include "control/line_connection.hpp"
#include "control/ascii/ascii_request.hpp"
#include "control/peer_credentials.hpp"
#include "bus/service/service_replies.hpp"
#include "bus/service/service_target.hpp"

#include <cobridge/ip_allow_list.hpp>

#include <poll.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <system_error>
#include <vector>

namespace cobridge::control {

struct AsciiServerOptions {
  std::size_t max_clients = 128;
  std::size_t max_line = 1024;
  std::chrono::milliseconds idle_timeout{60000};
  std::chrono::milliseconds sdo_timeout{1000};
  bool writes_enabled = false;
  IpAllowList write_allow;  // TCP clients whose writes are taken (empty: all)
  std::string write_group;  // Unix socket: root, the daemon's user or members write (empty: all)
};

class AsciiServer {
 public:
  AsciiServer(bus::ServiceTarget& services, AsciiServerOptions options);
  ~AsciiServer();
  AsciiServer(const AsciiServer&) = delete;
  AsciiServer& operator=(const AsciiServer&) = delete;

  // Binds the Unix socket (mode 0660; a stale file replaced) / the TCP port.
  // Errors: where = the path or address:port, the message = the step and errno text.
  [[nodiscard]] Error open_unix(const std::filesystem::path& path);
  [[nodiscard]] Error open_tcp(const std::string& address, std::uint16_t port);
  void close();
  [[nodiscard]] std::size_t clients() const noexcept { return clients_.size(); }

  void add_poll_fds(std::vector<pollfd>& fds);
  // After poll(): which descriptors are ready (poll_slot.hpp); optional.
  void note_ready(const std::vector<pollfd>& fds);
  canopen::TimePoint process(canopen::TimePoint now);

 private:
  struct Client : LineConnection {
    std::string who;        // for the log of writes
    bool may_write = false; // write_allow / write_group, decided at accept (writes_enabled per request)
    unsigned net = 1;       // "set network"
    int node = -1;          // "set node"; -1 = none
    std::chrono::milliseconds sdo_timeout{1000};
    std::uint64_t waiting_tag = 0;
    AsciiRequest pending;
    canopen::TimePoint idle_until{};
  };

  void accept_from(int listen_fd, bool tcp, canopen::TimePoint now);
  [[nodiscard]] bool may_write_unix(const PeerCredentials& creds) const;
  bool serve(Client& c, canopen::TimePoint now);
  void answer(Client& c, std::string_view line, canopen::TimePoint now);
  // The answer to a local request (set, info, help), or empty when queued.
  std::string run(Client& c, AsciiRequest r);
  // A request's node, SDO timeout, deadline and caller from the connection.
  static void fill_command(AsciiRequest& r, std::uint8_t node, std::chrono::milliseconds sdo_timeout,
                           const std::string& who);
  // Takes the results that came back: each client is free again and its
  // answer goes out in this turn (a client that left is gone with its result).
  void deliver(canopen::TimePoint now);
  void drop(Client& c);

  bus::ServiceTarget& services_;
  AsciiServerOptions options_;
  int unix_fd_ = -1;
  int tcp_fd_ = -1;
  std::filesystem::path unix_path_;
  std::vector<Client> clients_;
  std::shared_ptr<bus::ServiceReplies> replies_ = std::make_shared<bus::ServiceReplies>();
  std::uint64_t next_tag_ = 1;
  PollSlot unix_slot_;
  PollSlot tcp_slot_;
  PollSlot replies_slot_;
};

// The answer line to a finished ServiceRequest of request `r`.
[[nodiscard]] std::string ascii_answer(const AsciiRequest& r, const bus::ServiceResult& result);

}  // namespace cobridge::control
