// ControlServer: the daemon's side of the local control socket, the way
// `cobridge status` and `cobridge commission` talk to a running cobridged.
//
// A Unix stream socket (mode 0660, its directory created if missing, a stale
// socket file of a dead daemon replaced, a live one left alone) speaking a
// line protocol: each request is one line, each answer is one line holding
// one JSON document.
//
//   status             -> {"gateway": ..., "buses": [...], ...}  (StatusReport)
//   commission [BUS]   -> {"ok": true, "buses": [...]}   (every bus when BUS is left out)
//   capture-now [BUS]  -> {"ok": true, "buses": [...]}   (flight recorder; every bus when BUS is left out)
//                         (commission and capture-now are writes: see below)
//   capture-get NAME   -> {"ok": true, "name": ..., "text": "<the candump log>"}
//   acknowledge DEVICE -> {"ok": true, "buses": [...]}   (its contested configuration
//                         may be written again: a write, see below)
//   sdo-read, sdo-write, nmt, lss-set-node-id (control_request.hpp)
//                      -> {"ok": true, ...}  (control_answer.hpp), answered when
//                         the bus's control thread has run the command
//   a failure          -> {"ok": false, "error": {"code": ..., "where": ..., "message": ...}}
//
// Clients' commands go to a ServiceTarget (the daemon's BusRegistry, which
// app/ makes and hands to the buses and to this server): the daemon stays the one master of its buses.
// Writes (sdo-write, nmt, lss-set-node-id, commission, capture-now, acknowledge) are
// refused unless [control] writes_enabled is set and the caller (SO_PEERCRED) is root, the daemon's
// own user or a member of [control] write_group (a caller the kernel cannot
// name is none of them: peer_credentials.hpp); each write is logged
// with the caller's uid and pid. While a client's command runs, that client's
// next request waits; other clients are served meanwhile.
//
// A client may send several requests on one connection. No client can hold
// the daemon up: every socket is non-blocking, a request line must be
// complete within `client_timeout` of the connection or the previous answer
// (so a client trickling one byte a second is cut off), a line longer than
// `max_line` is answered with an error and the connection closed, an answer
// the client does not read within `client_timeout` is dropped with the
// connection, and there are at most `max_clients` connections.
//
// The CiA 309-3 ASCII gateway (ascii/ascii_server.hpp) is driven from here
// too, so the daemon's main loop serves it without a line of its own: it is
// opened once the first bus runs and the registry holds [ascii_gateway]
// enabled (socket: ascii_gateway.socket, default "ascii.sock" beside the
// control socket), and closed with the control socket.
//
// Thread: the daemon's main loop owns it, and every client connection for
// the connection's whole life: add_poll_fds() before poll(), process(now)
// after, like every component that waits on file descriptors. The handler
// is called from process(), on that thread. A client's SDO / NMT / LSS
// command runs on its bus's control thread, which only pushes the result to
// this server's ServiceReplies (its eventfd wakes the loop); the answer is
// formatted and written here, so one thread reads and writes a client's
// socket. While its command runs a client's socket is not polled: its next
// request waits there, in order, and the command's deadline bounds the wait.
#pragma once

#include "base/result.hpp"
#include "canopen/clock.hpp"
#include "control/control_request.hpp"
#include "bus/device_status.hpp"
#include "control/line_connection.hpp"
#include "control/ascii/ascii_server.hpp"
#include "control/peer_credentials.hpp"
#include "bus/service/service_replies.hpp"
#include "bus/service/service_target.hpp"
#include "control/status_report.hpp"

#include <poll.h>
#include <sys/types.h>

#include <chrono>
#include <cstddef>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace cobridge::control {

// What the control socket asks of the daemon. Implemented by main over the
// bus managers, by a fake in the tests.
class ControlHandler {
 public:
  virtual ~ControlHandler() = default;
  [[nodiscard]] virtual StatusReport status() = 0;
  // `bus` empty = every bus. The buses it acted on, or why it did not act
  // (kNotFound: no such bus).
  virtual Result<std::vector<std::string>> commission(std::string_view bus) = 0;
  // Flight recorder: a capture of `bus` (empty = every bus) with cause
  // "operator", written once its window closes. The buses it asked.
  virtual Result<std::vector<std::string>> capture_now(std::string_view /*bus*/) {
    return Error(Errc::kUnsupported, "no flight recorder");
  }
  // Drift restore: `device`'s contested objects (bus/restore_guard.hpp) may
  // be written again; `caller` goes on its timeline. The device's bus, or
  // kNotFound (no such device) / kInvalidArgument (nothing contested).
  virtual Result<std::vector<std::string>> acknowledge(std::string_view /*device*/, const std::string& /*caller*/) {
    return Error(Errc::kUnsupported, "no drift restore");
  }
  // The text of the capture file `name` (as the status lists it).
  [[nodiscard]] virtual Result<std::string> read_capture(std::string_view /*name*/) {
    return Error(Errc::kUnsupported, "no flight recorder");
  }
};

struct ControlServerOptions {
  std::chrono::milliseconds client_timeout{2000};
  std::size_t max_line = 256;
  std::size_t max_clients = 16;
  bus::ServiceTarget* services = nullptr;  // nullptr: no bus takes client commands
};

class ControlServer {
 public:
  explicit ControlServer(ControlHandler& handler, ControlServerOptions options = {});
  ~ControlServer();
  ControlServer(const ControlServer&) = delete;
  ControlServer& operator=(const ControlServer&) = delete;

  // Creates the socket directory, replaces a stale socket file, binds,
  // sets mode 0660 and listens. Fails with where = the path, the errno as
  // code; kind kUnavailable when another daemon listens there,
  // kInvalidArgument for a path too long or a file that is not a socket.
  [[nodiscard]] Error open(const std::filesystem::path& path);
  // Closes every connection and removes the socket file.
  void close();
  [[nodiscard]] bool is_open() const noexcept { return listen_fd_ >= 0; }
  [[nodiscard]] std::size_t clients() const noexcept { return clients_.size(); }

  // Appends the descriptors to wait on (the listening socket, each client
  // for reading or, while an answer is pending, writing).
  void add_poll_fds(std::vector<pollfd>& fds);
  // After poll() on those descriptors: which are ready (poll_slot.hpp).
  // Optional: without it process() tries every descriptor.
  void note_ready(const std::vector<pollfd>& fds);
  // Accepts, reads, answers and times out whatever is due; never blocks.
  // Returns the next client deadline (kNever when no client is connected).
  canopen::TimePoint process(canopen::TimePoint now);

 private:
  struct Client : LineConnection {
    canopen::TimePoint deadline{};
    bool close_after_write = false;
    PeerCredentials peer;
    std::uint64_t waiting_tag = 0;  // a command of this client runs (0: none)
    ControlRequest pending;         // that command, for its answer
  };

  void accept_clients(canopen::TimePoint now);
  // Returns false when the client is to be closed now.
  bool serve(Client& c, canopen::TimePoint now);
  void answer(Client& c, std::string_view line, canopen::TimePoint now);
  // Why `c` may not write to a bus ([control] writes_enabled, write_group);
  // empty when it may.
  [[nodiscard]] std::string write_refusal(const Client& c) const;
  // `commission [bus]`: a write (node-IDs change), checked and logged with the caller.
  std::string commission(const Client& c, const std::string& bus);
  // `capture-now [bus]`: a write too (the disk), checked and logged with the caller.
  std::string capture_now(const Client& c, const std::string& bus);
  // `act` when the write policy lets `c` write, its buses as the answer
  // (with `note`); refused (permission_denied) and logged otherwise.
  // `acknowledge DEVICE`: a write (the configuration is written again).
  std::string acknowledge(const Client& c, const std::string& device);
  std::string policed(const Client& c, std::string_view what, const std::string& where,
                      const std::function<Result<std::vector<std::string>>()>& act, const std::string& note);
  // A client's SDO/NMT/LSS command: checked, logged if a write, queued.
  void submit(Client& c, ControlRequest request, canopen::TimePoint now);
  // Takes the results that came back from the buses: each client is free
  // again and its answer goes out in this turn (a client that left is gone
  // with its result).
  void deliver(canopen::TimePoint now);
  // Opens the ASCII gateway once its settings are known (see above).
  void open_ascii_gateway();
  void drop(Client& c);

  ControlHandler& handler_;
  bus::BusRegistry no_buses_;  // the target when the options name none
  ControlServerOptions options_;
  bus::ServiceTarget& services_;
  std::shared_ptr<bus::ServiceReplies> replies_ = std::make_shared<bus::ServiceReplies>();
  std::uint64_t next_tag_ = 1;
  bool ascii_tried_ = false;
  std::unique_ptr<AsciiServer> ascii_;
  std::filesystem::path path_;
  int listen_fd_ = -1;
  dev_t socket_dev_ = 0;
  ino_t socket_ino_ = 0;
  std::vector<Client> clients_;
  PollSlot listen_slot_;
  PollSlot replies_slot_;
};

}  // namespace cobridge::control
