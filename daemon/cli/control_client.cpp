#include "cli/control_client.hpp"

#include <sys/socket.h>
#include <sys/time.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace cobridge::cli {

namespace {

// A connected socket with send and receive timeouts, or why there is none:
// kPermissionDenied when the socket may not be opened, else kUnavailable.
Result<int> connect_to(const std::string& path, int timeout_ms, bool* no_daemon) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof addr.sun_path) {
    return Error(Errc::kUnavailable, "control socket path \"" + path + "\" is empty or too long");
  }
  path.copy(addr.sun_path, path.size());
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    return Error(Errc::kUnavailable, std::string("socket: ") + std::strerror(errno));
  }
  timeval tv{timeout_ms / 1000, static_cast<suseconds_t>((timeout_ms % 1000) * 1000)};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const int err = errno;
    ::close(fd);
    Error why(Errc::kUnavailable, "cannot reach cobridged at " + path + ": " + std::strerror(err));
    if (err == ENOENT || err == ECONNREFUSED) why.message += " (is cobridged running? see --control)";
    if (no_daemon != nullptr) *no_daemon = err == ENOENT || err == ECONNREFUSED;
    if (err == EACCES || err == EPERM) {
      why.message += " (the socket, mode 0660, is for the service's user and group: ask to join that group)";
      why.kind = Errc::kPermissionDenied;
    }
    return why;
  }
  return fd;
}

// The first line of the answer (without its newline), or why none came:
// kTimeout when no answer came in time, else kUnavailable.
Result<std::string> read_answer(int fd, int timeout_ms) {
  std::string answer;
  char buf[4096];
  for (auto nl = answer.find('\n'); nl == std::string::npos; nl = answer.find('\n')) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n == 0) return Error(Errc::kUnavailable, "the daemon closed the connection without an answer");
    if (n < 0 && errno == EAGAIN) {
      return Error(Errc::kTimeout, "reading the answer: no answer within " + std::to_string(timeout_ms) + " ms");
    }
    if (n < 0) return Error(Errc::kUnavailable, std::string("reading the answer: ") + std::strerror(errno));
    answer.append(buf, static_cast<std::size_t>(n));
    if (answer.size() > (64u << 20) && answer.find('\n') == std::string::npos) {
      return Error(Errc::kUnavailable, "answer larger than 64 MiB");
    }
  }
  answer.resize(answer.find('\n'));
  return answer;
}

}  // namespace

Result<std::string> request(const std::string& path, const std::string& line, int timeout_ms, bool* no_daemon) {
  if (no_daemon != nullptr) *no_daemon = false;
  const Result<int> fd = connect_to(path, timeout_ms, no_daemon);
  if (!fd.ok()) return fd.error();
  const std::string out = line + "\n";
  if (::send(*fd, out.data(), out.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(out.size())) {
    Error failed(Errc::kUnavailable, std::string("sending the request: ") + std::strerror(errno));
    ::close(*fd);
    return failed;
  }
  Result<std::string> answer = read_answer(*fd, timeout_ms);
  ::close(*fd);
  return answer;
}

}  // namespace cobridge::cli
