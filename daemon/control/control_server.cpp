#include "control/control_server.hpp"

#include "base/error.hpp"

#include "control/control_answer.hpp"
#include "control/control_request.hpp"
#include "control/remote/awaited_results.hpp"
#include "bus/remote/connection_loan.hpp"
#include "bus/remote/direct_answer.hpp"

#include "canopen/nmt.hpp"
#include "sys/logging.hpp"

#include <fcntl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>

namespace cobridge::gateway {
namespace {

using canopen::kNever;
using canopen::TimePoint;

}  // namespace

ControlServer::ControlServer(ControlHandler& handler, ControlServerOptions options)
    : handler_(handler),
      options_(options),
      remote_(options.remote != nullptr ? *options.remote : static_cast<RemoteTarget&>(no_buses_)) {}

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
  const auto access = remote_.access();
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
  ascii_ = std::make_unique<AsciiServer>(remote_, o);
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
    if (c.waiting_tag != 0) {
      // Nothing to write until its result is back; its next request tells
      // us to collect a result the bus thread pushed quietly.
      if (c.wake_asked || c.lent) c.slot.skip();
      else c.slot.add(fds, c.fd, POLLIN);
      continue;
    }
    const bool writing = c.writing();
    c.slot.add(fds, c.fd, writing ? POLLOUT : POLLIN);
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
  collect(now, replies_slot_.take());
  if (!ascii_tried_ && listen_fd_ >= 0) open_ascii_gateway();
  TimePoint next = ascii_ ? ascii_->process(now) : kNever;
  for (auto it = clients_.begin(); it != clients_.end();) {
    // A request already buffered (pipelined) is due now: poll will not wake for it.
    const bool buffered = it->waiting_tag == 0 && it->in.find('\n') != std::string::npos;
    const bool try_io = it->slot.take();
    if (try_io && it->waiting_tag != 0) await_result(*it, now);
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
    c.direct = std::make_shared<DirectAnswer>(fd);
    clients_.push_back(std::move(c));
  }
}

bool ControlServer::serve(Client& c, TimePoint now) {
  if (c.waiting_tag != 0) return now < c.deadline;  // its command runs; deliver() answers
  // An answer is read before the next request is looked at.
  if (!c.flush()) return false;
  if (!c.out.empty()) return now < c.deadline;
  if (c.close_after_write || c.peer_closed) return false;

  c.read(options_.max_line);

  const std::size_t nl = c.in.find('\n');
  if (nl != std::string::npos && nl <= options_.max_line) {
    // Taken out first: what stays buffered decides whether the connection
    // may be lent with the command (lend_with).
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
  const auto access = remote_.access();
  if (!access || !access->control.writes_enabled)
    return "writes through the control socket are disabled ([control] writes_enabled = false)";
  return write_group_refusal(c.peer, access->control.write_group, ::geteuid());
}

// Commissioning reassigns node-IDs (LSS): a bus write like any other, under
// the same policy, logged with its caller.
std::string ControlServer::commission(const Client& c, const std::string& bus) {
  const auto log = sys::logger("gateway");
  const std::string caller = c.peer.to_string() + " (control socket)";
  const std::string where = bus.empty() ? std::string("every bus") : "bus '" + bus + "'";
  if (std::string refusal = write_refusal(c); !refusal.empty()) {
    log->warn("control socket: commission of {} refused to {}: {}", where, caller, refusal);
    return error_answer(Error(Errc::kPermissionDenied, refusal, where));
  }
  const ControlResult r = handler_.commission(bus);
  if (!r.ok) return error_answer(Error(Errc::kNotFound, r.message));
  log->info("control socket: commission of {} by {}", where, caller);
  return commission_answer(r.buses, r.message);
}

void ControlServer::submit(Client& c, ControlRequest request, TimePoint now) {
  RemoteCommand& cmd = request.command;
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
  const auto tag = cmd.tag;
  const auto wait = cmd.deadline + std::chrono::seconds(2);
  if (Error e = remote_.submit(request.bus, with_direct_answer(c, request), replies_)) {
    if (c.direct) c.direct->arm({});
    c.out = error_answer(e);
    return;
  }
  c.waiting_tag = tag;
  c.pending = std::move(request);
  c.deadline = now + wait;
}

DirectAnswer::Format ControlServer::answer_line(ControlRequest request) {
  return [request = std::move(request)](const RemoteResult& r) { return remote_answer(request, r) + '\n'; };
}

RemoteCommand ControlServer::with_direct_answer(Client& c, const ControlRequest& request) const {
  RemoteCommand cmd = request.command;
  // Only while nothing else is owed to the client: its answers stay in order.
  if (!c.direct || !c.out.empty()) return cmd;
  // Its next request already here waits for this result: a wake-up, not a
  // quiet hand-back that would leave it for the loop's tick.
  cmd.wake_owner = !c.in.empty();
  c.direct->arm(answer_line(request));
  cmd.direct = c.direct;
  lend_with(c, cmd, request.bus);
  return cmd;
}

void ControlServer::lend_with(Client& c, RemoteCommand& cmd, const std::string& bus) const {
  // Reads only (writes are checked and logged here), and only while nothing
  // of the client is buffered here: then one thread reads it at a time.
  if (cmd.op != RemoteOp::sdo_upload || !c.in.empty() || c.peer_closed || c.skipping || c.close_after_write) return;
  auto loan = std::make_shared<ConnectionLoan>();
  loan->connection = c.direct;
  loan->max_line = options_.max_line;
  loan->idle_timeout = options_.client_timeout;
  loan->take = [bus, caller = cmd.caller](std::string_view line, DirectAnswer& connection) {
    ControlRequest next = parse_control_request(line);
    std::optional<RemoteCommand> taken;
    if (next.kind != ControlRequest::Kind::remote || next.command.op != RemoteOp::sdo_upload || next.bus != bus)
      return taken;
    next.command.caller = caller;
    taken = next.command;
    connection.arm(answer_line(std::move(next)));
    return taken;
  };
  cmd.loan = std::move(loan);
}

void ControlServer::await_result(Client& c, TimePoint now) {
  c.wake_asked = true;
  collect(now, false);
}

void ControlServer::collect(TimePoint now, bool drain) {
  collect_results(clients_, *replies_, drain, [&](bool d) { deliver(now, d); });
}

void ControlServer::deliver(TimePoint now, bool drain) {
  for (auto& r : drain ? replies_->take() : replies_->take_quiet()) {
    for (auto& c : clients_) {
      if (c.waiting_tag != r.tag) continue;
      if (take_loan_news(c, r)) {
        c.deadline = kNever;  // the bus thread times an idle client out
        break;
      }
      // A connection given back (r.returned) has its input and no answer.
      if (!r.returned && r.answer.empty()) {
        c.out += remote_answer(c.pending, r);
        c.out += '\n';
      } else if (!r.returned) {
        // The bus thread sent the answer, or its start: the rest goes from
        // here (the buffer was empty when the command was queued).
        c.out = std::move(r.answer);
        c.out_done = r.answer_sent;
      }
      c.waiting_tag = 0;
      c.wake_asked = false;
      c.pending = {};
      // An idle client given back is past its time: told so, then closed.
      c.deadline = r.idle ? now : now + options_.client_timeout;
      c.slot.mark();  // its answer goes out in this turn
      break;
    }
  }
}

void ControlServer::drop(Client& c) {
  if (c.waiting_tag != 0 && c.direct) c.direct->shut();
  c.direct.reset();
  if (c.fd >= 0) ::close(c.fd);
  c.fd = -1;
}

}  // namespace cobridge::gateway
