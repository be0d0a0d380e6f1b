#include "control/ascii/ascii_server.hpp"

#include "sys/logging.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdio>

namespace cobridge::control {
namespace {

using canopen::kNever;
using canopen::TimePoint;

constexpr const char* kHelp =
    "commands: [seq] [[net] node] r|read idx sub [type] | w|write idx sub type value | start | stop | preop | "
    "reset node | reset comm; [seq] [net] lss_switch_glob 0|1 | lss_switch_sel v p r s | lss_set_node n | "
    "lss_store | lss_inquire_addr [0..3] | lss_get_node; [seq] [net] set network|node|sdo_timeout n; "
    "[seq] info version; types b i8 i16 i32 i64 u8 u16 u32 u64 x8 x16 x32 x64 r32 r64 vs os";

// where = the socket (path or address:port); the message = the step and the errno text.
Error sys_error(int err, const std::string& what, const std::string& where, Errc kind = Errc::kFailed) {
  const std::error_code ec(err, std::system_category());
  return Error(kind, what + ": " + ec.message(), where, ec);
}

// Why a client's write was refused: a Unix-socket client is outside
// write_group; a TCP one outside write_allow, and a loopback one while
// write_allow is empty (IpAllowList::allows_writer).
std::string refusal_reason(const std::string& who, bool allow_list_empty) {
  if (who.rfind("tcp ", 0) != 0) return "not in write_group";
  if (allow_list_empty && who.rfind("tcp 127.", 0) == 0)
    return "a loopback client writes only when write_allow lists it";
  return "not in write_allow";
}

}  // namespace

AsciiServer::AsciiServer(bus::ServiceTarget& services, AsciiServerOptions options) : services_(services), options_(options) {}

AsciiServer::~AsciiServer() { close(); }

Error AsciiServer::open_unix(const std::filesystem::path& path) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  const std::string text = path.string();
  if (text.empty() || text.size() >= sizeof addr.sun_path) return sys_error(ENAMETOOLONG, "socket path too long", text, Errc::kInvalidArgument);
  text.copy(addr.sun_path, text.size());
  std::error_code ec;
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path(), ec);
  struct stat st {};
  if (::lstat(text.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) return sys_error(EEXIST, "exists and is not a socket", text, Errc::kInvalidArgument);
    ::unlink(text.c_str());  // the control socket proved this daemon is the only one
  }
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) return sys_error(errno, "socket()", text);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0 || ::chmod(text.c_str(), 0660) != 0 ||
      ::listen(fd, 128) != 0) {
    const int err = errno;
    ::close(fd);
    return sys_error(err, "binding", text);
  }
  unix_fd_ = fd;
  unix_path_ = path;
  return {};
}

Error AsciiServer::open_tcp(const std::string& address, std::uint16_t port) {
  const std::string where = address + ":" + std::to_string(port);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  if (::inet_pton(AF_INET, address.c_str(), &addr.sin_addr) != 1) return sys_error(EINVAL, "not an IPv4 address", where, Errc::kInvalidArgument);
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) return sys_error(errno, "socket()", where);
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0 || ::listen(fd, 128) != 0) {
    const int err = errno;
    ::close(fd);
    return sys_error(err, "binding", where);
  }
  tcp_fd_ = fd;
  return {};
}

void AsciiServer::close() {
  for (auto& c : clients_) drop(c);
  clients_.clear();
  if (unix_fd_ >= 0) {
    ::close(unix_fd_);
    ::unlink(unix_path_.c_str());
    unix_fd_ = -1;
  }
  if (tcp_fd_ >= 0) ::close(tcp_fd_);
  tcp_fd_ = -1;
}

void AsciiServer::add_poll_fds(std::vector<pollfd>& fds) {
  if (unix_fd_ >= 0) unix_slot_.add(fds, unix_fd_, POLLIN);
  if (tcp_fd_ >= 0) tcp_slot_.add(fds, tcp_fd_, POLLIN);
  replies_slot_.add(fds, replies_->fd(), POLLIN);
  for (auto& c : clients_) {
    // While its command runs, a client's next lines wait in the socket.
    if (c.writing()) c.slot.add(fds, c.fd, POLLOUT);
    else if (c.waiting_tag == 0) c.slot.add(fds, c.fd, POLLIN);
    else c.slot.skip();
  }
}

void AsciiServer::note_ready(const std::vector<pollfd>& fds) {
  unix_slot_.note(fds);
  tcp_slot_.note(fds);
  replies_slot_.note(fds);
  for (auto& c : clients_) c.slot.note(fds);
}

TimePoint AsciiServer::process(TimePoint now) {
  if (unix_fd_ >= 0 && unix_slot_.take()) accept_from(unix_fd_, false, now);
  if (tcp_fd_ >= 0 && tcp_slot_.take()) accept_from(tcp_fd_, true, now);
  if (replies_slot_.take()) deliver(now);
  TimePoint next = kNever;
  for (auto it = clients_.begin(); it != clients_.end();) {
    const bool buffered = it->waiting_tag == 0 && it->in.find('\n') != std::string::npos;
    const bool try_io = it->slot.take();
    if ((try_io || buffered || now >= it->idle_until) && !serve(*it, now)) {
      drop(*it);
      it = clients_.erase(it);
      continue;
    }
    const bool due = it->waiting_tag == 0 && it->in.find('\n') != std::string::npos;
    next = std::min(next, due ? now : it->idle_until);
    ++it;
  }
  return next;
}

// The Unix socket's write_group, as the control socket's: root, the
// daemon's own user, or a member (by the groups the kernel recorded).
bool AsciiServer::may_write_unix(const PeerCredentials& creds) const {
  return write_group_refusal(creds, options_.write_group, ::geteuid()).empty();
}

void AsciiServer::accept_from(int listen_fd, bool tcp, TimePoint now) {
  while (true) {
    sockaddr_in peer{};
    unsigned len = sizeof peer;
    const int fd = accept_connection(listen_fd, "ascii gateway", tcp ? &peer : nullptr, tcp ? &len : nullptr);
    if (fd < 0) return;
    if (clients_.size() >= options_.max_clients) {
      refuse_connection(fd, ascii_line(ascii_error("0", AsciiError::internal_state)));
      continue;
    }
    Client c;
    c.fd = fd;
    c.sdo_timeout = options_.sdo_timeout;
    c.idle_until = now + options_.idle_timeout;
    if (tcp) {
      char a[INET_ADDRSTRLEN] = "?";
      ::inet_ntop(AF_INET, &peer.sin_addr, a, sizeof a);
      c.who = std::string("tcp ") + a + ":" + std::to_string(ntohs(peer.sin_port));
      c.may_write = options_.write_allow.allows_writer_v4(ntohl(peer.sin_addr.s_addr));  // the listener is IPv4
    } else {
      const PeerCredentials creds = peer_credentials(fd);
      c.who = creds.to_string();
      c.may_write = may_write_unix(creds);
    }
    clients_.push_back(std::move(c));
  }
}

bool AsciiServer::serve(Client& c, TimePoint now) {
  if (!c.flush()) return false;
  if (c.waiting_tag != 0) return true;  // deliver() answers; the bus bounds the wait
  if (!c.out.empty()) return now < c.idle_until;
  c.read(options_.max_line);
  const std::size_t nl = c.in.find('\n');
  if (nl != std::string::npos && nl <= options_.max_line) {
    const std::string line = c.take_line();
    c.idle_until = now + options_.idle_timeout;
    answer(c, line, now);
  } else if (c.in.size() > options_.max_line) {
    // CiA 309-3 gives no limit; ours is max_line: the line is answered as a
    // syntax error and skipped up to its end.
    c.out += ascii_line(ascii_error("0", AsciiError::syntax));
    c.in.clear();
    c.skipping = true;
  } else if (c.peer_closed) {
    return false;
  } else if (now >= c.idle_until) {
    return false;
  }
  if (!c.flush()) return false;
  return true;
}

void AsciiServer::answer(Client& c, std::string_view line, TimePoint now) {
  (void)now;
  if (line.find_first_not_of(" \t\r") == std::string_view::npos) return;  // empty lines are ignored
  AsciiRequest r = parse_ascii_request(line);
  const std::string reply = run(c, std::move(r));
  if (!reply.empty()) c.out += ascii_line(reply);
}

std::string AsciiServer::run(Client& c, AsciiRequest r) {
  const std::string seq = r.seq.empty() ? "0" : r.seq;
  switch (r.kind) {
    case AsciiRequest::Kind::invalid: return ascii_error(seq, r.error);
    case AsciiRequest::Kind::help: return "[" + seq + "] " + kHelp;
    case AsciiRequest::Kind::info: return "[" + seq + "] cobridge CiA 309-3 gateway, nets 1.." +
                                          std::to_string(services_.buses().size());
    case AsciiRequest::Kind::set_network:
      if (r.value == 0 || r.value > services_.buses().size()) return ascii_error(seq, AsciiError::unsupported_net);
      c.net = r.value;
      return ascii_ok(seq);
    case AsciiRequest::Kind::set_node: c.node = static_cast<int>(r.value); return ascii_ok(seq);
    case AsciiRequest::Kind::set_sdo_timeout: c.sdo_timeout = std::chrono::milliseconds(r.value); return ascii_ok(seq);
    default: break;
  }
  const unsigned net = r.net != 0 ? r.net : c.net;
  if (net == 0 || net > services_.buses().size()) return ascii_error(seq, AsciiError::unsupported_net);
  bus::ServiceRequest& cmd = r.command;
  if (r.kind != AsciiRequest::Kind::lss) {
    const int node = r.node >= 0 ? r.node : c.node;
    if (node < 0) return ascii_error(seq, AsciiError::no_default_node);
    const bool nmt_all = r.kind == AsciiRequest::Kind::nmt && node == 0;
    if (!nmt_all && (node < 1 || node > 127)) return ascii_error(seq, AsciiError::unsupported_node);
    cmd.node = static_cast<std::uint8_t>(node);
  }
  fill_command(r, cmd.node, c.sdo_timeout, c.who);
  if (cmd.is_write()) {
    if (!options_.writes_enabled) return ascii_error(seq, AsciiError::not_supported);
    if (!c.may_write) {
      sys::logger("gateway")->warn("ascii gateway: {} on net {} node {} refused to {}: {}", to_string(cmd.op), net,
                                   cmd.node, cmd.caller, refusal_reason(c.who, options_.write_allow.empty()));
      return ascii_error(seq, AsciiError::not_supported);
    }
    sys::logger("gateway")->info("ascii gateway: {} on net {} node {} by {}", to_string(cmd.op), net, cmd.node, cmd.caller);
  }
  cmd.tag = next_tag_++;
  r.seq = seq;
  if (Error e = services_.submit("#" + std::to_string(net), cmd, replies_))
    return ascii_error(seq, e.kind == Errc::kNotFound ? AsciiError::unsupported_net : AsciiError::internal_state);
  c.waiting_tag = cmd.tag;
  c.pending = std::move(r);
  return {};
}

void AsciiServer::fill_command(AsciiRequest& r, std::uint8_t node, std::chrono::milliseconds sdo_timeout,
                               const std::string& who) {
  bus::ServiceRequest& cmd = r.command;
  cmd.node = node;
  cmd.sdo_timeout = sdo_timeout;
  cmd.deadline = std::max(std::chrono::milliseconds(10000), 8 * sdo_timeout);
  cmd.caller = who + " (CiA 309-3 gateway)";
}

void AsciiServer::deliver(TimePoint now) {
  for (auto& res : replies_->take()) {
    const auto it = std::find_if(clients_.begin(), clients_.end(),
                                 [&](const Client& c) { return c.waiting_tag == res.tag; });
    if (it == clients_.end()) continue;  // its client left
    it->out += ascii_line(ascii_answer(it->pending, res));
    it->waiting_tag = 0;
    it->pending = {};
    it->idle_until = now + options_.idle_timeout;
    it->slot.mark();  // its answer goes out in this turn
  }
}

std::string ascii_answer(const AsciiRequest& r, const bus::ServiceResult& result) {
  if (result.error) {
    if (result.abort_code != 0) return ascii_abort(r.seq, result.abort_code);
    if (r.kind == AsciiRequest::Kind::read || r.kind == AsciiRequest::Kind::write) {
      if (result.error.kind == Errc::kTimeout && result.error.code) return ascii_abort(r.seq, 0x05040000);
    }
    if (r.kind == AsciiRequest::Kind::lss && result.error.code.category().name() == std::string_view("lss_slave")) {
      const auto last = r.command.lss_steps.empty() ? bus::LssStep::Kind::switch_global : r.command.lss_steps.back().kind;
      return ascii_error(r.seq, last == bus::LssStep::Kind::store ? AsciiError::lss_store
                                : last == bus::LssStep::Kind::set_node_id ? AsciiError::lss_node_id
                                                                      : AsciiError::lss_implementation);
    }
    return ascii_error(r.seq, result.error.kind == Errc::kTimeout ? AsciiError::timeout : AsciiError::internal_state);
  }
  if (r.kind == AsciiRequest::Kind::read) {
    const auto text = ascii_format(r.type, result.data);
    return text ? "[" + r.seq + "] " + *text : ascii_abort(r.seq, 0x06070010);  // length of the type does not match
  }
  if (r.kind == AsciiRequest::Kind::lss && !result.values.empty()) {
    std::string out = "[" + r.seq + "]";
    char buf[16];
    const bool node_id = r.command.lss_steps.back().kind == bus::LssStep::Kind::inquire_node_id;
    for (const auto v : result.values) {
      std::snprintf(buf, sizeof buf, node_id ? "%u" : "0x%08X", node_id ? (v & 0xFF) : v);
      out += std::string(" ") + buf;
    }
    return out;
  }
  return ascii_ok(r.seq);
}

void AsciiServer::drop(Client& c) {
  if (c.fd >= 0) ::close(c.fd);
  c.fd = -1;
}

}  // namespace cobridge::control
