#include "control/control_server.hpp"

#include "base/error.hpp"

#include "control/control_answer.hpp"
#include "control/control_request.hpp"

#include "canopen/nmt.hpp"
#include "sys/logging.hpp"

#include <fcntl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <functional>
#include <cerrno>

namespace cobridge::control {
namespace {

using canopen::kNever;
using canopen::TimePoint;

std::string bus_where(const std::string& bus) { return bus.empty() ? std::string("every bus") : "bus '" + bus + "'"; }

}  // namespace

ControlServer::ControlServer(ControlHandler& handler, ControlServerOptions options)
    : handler_(handler),
      options_(options),
      services_(options.services != nullptr ? *options.services : static_cast<bus::ServiceTarget&>(no_buses_)) {}

ControlServer::~ControlServer() { close(); }

Error ControlServer::open(const std::filesystem::path& path) {
  const std::string text = path.string();
  // where = the socket path; the message = the step and the errno text.
  auto fail = [&](int err, const std::string& what, Errc kind = Errc::kFailed) {
    const std::error_code ec(err, std::system_category());
    return Error(kind, what + ": " + ec.message(), text, ec);
  };
  close();
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (text.empty() || text.size() >= sizeof addr.sun_path)
    return fail(ENAMETOOLONG, "control socket path of " + std::to_string(text.size()) + " bytes (at most " +
                                  std::to_string(sizeof addr.sun_path - 1) + ")",
                Errc::kInvalidArgument);
  text.copy(addr.sun_path, text.size());

  std::error_code ec;
  if (path.has_parent_path()) {
    std::filesystem::create_directories(path.parent_path(), ec);
    if (ec) return fail(ec.value(), "creating " + path.parent_path().string());
  }

  // A socket file left by a daemon that died is replaced; one that answers
  // belongs to a running daemon, and a second daemon on the same buses would
  // fight the first, so that is an error. Anything else is not ours to delete.
  struct stat st {};
  if (::lstat(text.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) return fail(EEXIST, "exists and is not a socket", Errc::kInvalidArgument);
    const int probe = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (probe < 0) return fail(errno, "socket()");
    const bool alive = ::connect(probe, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0;
    ::close(probe);
    if (alive) return fail(EADDRINUSE, "another daemon is listening on it", Errc::kUnavailable);
    if (::unlink(text.c_str()) != 0) return fail(errno, "removing the stale socket");
  }

  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) return fail(errno, "socket()");
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const int err = errno;
    ::close(fd);
    return fail(err, "binding");
  }
  // Owner and group (operators in the service's group) may talk to it.
  if (::chmod(text.c_str(), 0660) != 0 || ::listen(fd, 16) != 0 || ::lstat(text.c_str(), &st) != 0) {
    const int err = errno;
    ::close(fd);
    ::unlink(text.c_str());
    return fail(err, "setting up (chmod, listen)");
  }
  listen_fd_ = fd;
  path_ = path;
  socket_dev_ = st.st_dev;
  socket_ino_ = st.st_ino;
  return {};
}

void ControlServer::open_ascii_gateway() {
  const auto access = services_.access();
  if (!access) return;  // no bus runs yet
  ascii_tried_ = true;
  const config::AsciiGatewaySettings& a = access->ascii;
  if (!a.enabled) return;
  AsciiServerOptions o;
  o.max_clients = a.max_clients;
  o.sdo_timeout = std::chrono::milliseconds(a.sdo_timeout_ms);
  o.writes_enabled = a.writes_enabled;
  for (const std::string& net : a.write_allow) (void)o.write_allow.add(net);  // checked by the loader
  o.write_group = a.write_group;
  ascii_ = std::make_unique<AsciiServer>(services_, o);
  const auto path = a.socket.empty() ? path_.parent_path() / "ascii.sock" : a.socket;
  const auto log = sys::logger("gateway");
  if (const Error e = ascii_->open_unix(path)) log->error("ascii gateway: {}", e.to_string());
  else log->info("ascii gateway (CiA 309-3): {}{}", path.string(), a.writes_enabled ? "" : " (read-only)");
  if (a.tcp_port != 0) {
    if (const Error e = ascii_->open_tcp(a.bind, a.tcp_port)) log->error("ascii gateway: {}", e.to_string());
    else log->info("ascii gateway (CiA 309-3): tcp {}:{}", a.bind, a.tcp_port);
  }
}

void ControlServer::close() {
  ascii_.reset();
  ascii_tried_ = false;
  for (auto& c : clients_) drop(c);
  clients_.clear();
  if (listen_fd_ < 0) return;
  ::close(listen_fd_);
  listen_fd_ = -1;
  // Only remove the file if it is still the one we bound (not a successor's).
  struct stat st {};
  if (::lstat(path_.c_str(), &st) == 0 && st.st_dev == socket_dev_ && st.st_ino == socket_ino_)
    ::unlink(path_.c_str());
}

void ControlServer::add_poll_fds(std::vector<pollfd>& fds) {
  if (listen_fd_ >= 0) listen_slot_.add(fds, listen_fd_, POLLIN);
  replies_slot_.add(fds, replies_->fd(), POLLIN);
  if (ascii_) ascii_->add_poll_fds(fds);
  for (auto& c : clients_) {
    // A client whose command runs has nothing owed yet, and its next
    // request waits in the socket until the result is here.
    if (c.waiting_tag != 0) c.slot.skip();
    else c.slot.add(fds, c.fd, c.writing() ? POLLOUT : POLLIN);
  }
}

void ControlServer::note_ready(const std::vector<pollfd>& fds) {
  listen_slot_.note(fds);
  replies_slot_.note(fds);
  if (ascii_) ascii_->note_ready(fds);
  for (auto& c : clients_) c.slot.note(fds);
}

TimePoint ControlServer::process(TimePoint now) {
  if (listen_fd_ >= 0 && listen_slot_.take()) accept_clients(now);
  if (replies_slot_.take()) deliver(now);
  if (!ascii_tried_ && listen_fd_ >= 0) open_ascii_gateway();
  TimePoint next = ascii_ ? ascii_->process(now) : kNever;
  for (auto it = clients_.begin(); it != clients_.end();) {
    // A request already buffered (pipelined) is due now: poll will not wake for it.
    const bool buffered = it->waiting_tag == 0 && it->in.find('\n') != std::string::npos;
    const bool try_io = it->slot.take();
    if ((try_io || buffered || now >= it->deadline) && !serve(*it, now)) {
      drop(*it);
      it = clients_.erase(it);
      continue;
    }
    const bool due = it->waiting_tag == 0 && it->in.find('\n') != std::string::npos;
    next = std::min(next, due ? now : it->deadline);
    ++it;
  }
  return next;
}

void ControlServer::accept_clients(TimePoint now) {
  while (true) {
    const int fd = accept_connection(listen_fd_, "control socket");
    if (fd < 0) return;
    if (clients_.size() >= options_.max_clients) {
      refuse_connection(fd, error_answer(Error(Errc::kUnavailable, "too many clients (limit " +
                                                                      std::to_string(options_.max_clients) + ")")) +
                                "\n");
      continue;
    }
    Client c;
    c.fd = fd;
    c.deadline = now + options_.client_timeout;
    c.peer = peer_credentials(fd);
    clients_.push_back(std::move(c));
  }
}

bool ControlServer::serve(Client& c, TimePoint now) {
  if (c.waiting_tag != 0) return now < c.deadline;  // its command runs; deliver() answers
  // An answer is read before the next request is looked at; the window
  // for that request starts once the whole answer is out (a long answer
  // to a reading client does not eat its next request's time).
  const bool was_writing = c.writing();
  if (!c.flush()) return false;
  if (!c.out.empty()) return now < c.deadline;
  if (was_writing) c.deadline = now + options_.client_timeout;
  if (c.close_after_write || c.peer_closed) return false;

  c.read(options_.max_line);

  const std::size_t nl = c.in.find('\n');
  if (nl != std::string::npos && nl <= options_.max_line) {
    const std::string line = c.in.substr(0, nl);
    c.in.erase(0, nl + 1);
    answer(c, line, now);
  } else if (c.in.size() > options_.max_line) {
    c.out = error_answer(Error(Errc::kInvalidArgument,
                               "request line longer than " + std::to_string(options_.max_line) + " bytes")) +
            "\n";
    c.close_after_write = true;
    c.in.clear();
  } else if (c.peer_closed) {
    // End of input: a last line without newline still counts (printf status | nc -U).
    if (c.in.find_first_not_of(" \t\r") != std::string::npos) answer(c, c.in, now);
    c.in.clear();
    c.close_after_write = true;
    if (c.waiting_tag != 0) return true;  // answered when its command is done
  } else if (now >= c.deadline) {
    const std::string late =
        error_answer(Error(Errc::kTimeout, "request not completed within " +
                                               std::to_string(options_.client_timeout.count()) + " ms")) +
        "\n";
    (void)::send(c.fd, late.data(), late.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    return false;
  } else {
    return true;
  }
  if (c.waiting_tag != 0) return true;
  // Most answers fit the socket buffer: hand this one over right away.
  if (!c.flush()) return false;
  if (!c.out.empty()) return now < c.deadline;
  return !c.close_after_write;
}

void ControlServer::answer(Client& c, std::string_view line, TimePoint now) {
  ControlRequest req = parse_control_request(line);
  std::string reply;
  if (req.kind == ControlRequest::Kind::invalid) {
    reply = error_answer(req.error);
  } else if (req.kind == ControlRequest::Kind::status) {
    reply = to_json(handler_.status());
  } else if (req.kind == ControlRequest::Kind::commission) {
    reply = commission(c, req.bus);
  } else if (req.kind == ControlRequest::Kind::capture_now) {
    reply = capture_now(c, req.bus);
  } else if (req.kind == ControlRequest::Kind::acknowledge) {
    reply = acknowledge(c, req.name);
  } else if (req.kind == ControlRequest::Kind::capture_get) {
    const Result<std::string> text = handler_.read_capture(req.name);
    reply = !text.ok() ? error_answer(text.error()) : capture_answer(req.name, text.value());
  } else {
    submit(c, std::move(req), now);
    if (c.waiting_tag != 0) return;
    reply = std::exchange(c.out, {});
  }
  c.out += reply;
  c.out += '\n';
  c.deadline = now + options_.client_timeout;
}

std::string ControlServer::write_refusal(const Client& c) const {
  const auto access = services_.access();
  if (!access || !access->control.writes_enabled)
    return "writes through the control socket are disabled ([control] writes_enabled = false)";
  return write_group_refusal(c.peer, access->control.write_group, ::geteuid());
}

// Commissioning reassigns node-IDs (LSS): a bus write like any other, under
// the same policy, logged with its caller.
std::string ControlServer::commission(const Client& c, const std::string& bus) {
  return policed(c, "commission", bus_where(bus), [&] { return handler_.commission(bus); }, {});
}

// A capture writes the disk (flash wear) and its file holds every frame of
// the bus: under the write policy too, logged with its caller (docs/security.md).
std::string ControlServer::capture_now(const Client& c, const std::string& bus) {
  return policed(c, "capture now", bus_where(bus), [&] { return handler_.capture_now(bus); },
                 "written once the window closes (capture_after_s)");
}

// A contested object is one the gateway stopped writing back to: writing it
// again is the operator's decision, under the write policy, logged with the
// caller (who also goes on the device's timeline).
std::string ControlServer::acknowledge(const Client& c, const std::string& device) {
  const std::string caller = c.peer.to_string() + " (control socket)";
  return policed(c, "acknowledge", "device '" + device + "'", [&] { return handler_.acknowledge(device, caller); },
                 "its contested configuration may be written again");
}

std::string ControlServer::policed(const Client& c, std::string_view what, const std::string& where,
                                   const std::function<Result<std::vector<std::string>>()>& act,
                                   const std::string& note) {
  const auto log = sys::logger("gateway");
  const std::string caller = c.peer.to_string() + " (control socket)";
  if (std::string refusal = write_refusal(c); !refusal.empty()) {
    log->warn("control socket: {} of {} refused to {}: {}", what, where, caller, refusal);
    return error_answer(Error(Errc::kPermissionDenied, refusal, where));
  }
  const Result<std::vector<std::string>> buses = act();
  if (!buses.ok()) return error_answer(buses.error());
  log->info("control socket: {} of {} by {}", what, where, caller);
  return commission_answer(buses.value(), note);
}

void ControlServer::submit(Client& c, ControlRequest request, TimePoint now) {
  bus::ServiceRequest& cmd = request.command;
  cmd.caller = c.peer.to_string() + " (control socket)";
  if (cmd.is_write()) {
    const auto log = sys::logger("gateway");
    if (std::string refusal = write_refusal(c); !refusal.empty()) {
      log->warn("control socket: {} refused to {}: {}", to_string(cmd.op), cmd.caller, refusal);
      c.out = error_answer(Error(Errc::kPermissionDenied, refusal, "bus '" + request.bus + "'"));
      return;
    }
    log->info("control socket: {} on bus {} node {} by {}", to_string(cmd.op), request.bus, cmd.node, cmd.caller);
  }
  cmd.tag = next_tag_++;
  const auto wait = cmd.deadline + std::chrono::seconds(2);
  if (Error e = services_.submit(request.bus, cmd, replies_)) {
    c.out = error_answer(e);
    return;
  }
  c.waiting_tag = cmd.tag;
  c.pending = std::move(request);
  c.deadline = now + wait;
}

void ControlServer::deliver(TimePoint now) {
  for (auto& r : replies_->take()) {
    const auto it = std::find_if(clients_.begin(), clients_.end(),
                                 [&](const Client& c) { return c.waiting_tag == r.tag; });
    if (it == clients_.end()) continue;  // its client left
    it->out += service_answer(it->pending, r);
    it->out += '\n';
    it->waiting_tag = 0;
    it->pending = {};
    it->deadline = now + options_.client_timeout;
    it->slot.mark();  // its answer goes out in this turn
  }
}

void ControlServer::drop(Client& c) {
  if (c.fd >= 0) ::close(c.fd);
  c.fd = -1;
}

}  // namespace cobridge::control
