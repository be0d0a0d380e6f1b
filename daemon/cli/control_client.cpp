#include "cli/control_client.hpp"

#include <sys/socket.h>
#include <sys/time.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace cobridge::cli {

Result<std::string> request(const std::string& path, const std::string& line, int timeout_ms, bool* no_daemon) {
  std::string error;
  Errc kind = Errc::kUnavailable;
  const auto failed = [&]() -> Result<std::string> { return Error(kind, error); };
  if (no_daemon != nullptr) *no_daemon = false;
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof addr.sun_path) {
    error = "control socket path \"" + path + "\" is empty or too long";
    return failed();
  }
  path.copy(addr.sun_path, path.size());
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    error = std::string("socket: ") + std::strerror(errno);
    return failed();
  }
  timeval tv{timeout_ms / 1000, static_cast<suseconds_t>((timeout_ms % 1000) * 1000)};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const int err = errno;
    ::close(fd);
    error = "cannot reach cobridged at " + path + ": " + std::strerror(err);
    if (err == ENOENT || err == ECONNREFUSED) error += " (is cobridged running? see --control)";
    if (no_daemon != nullptr) *no_daemon = err == ENOENT || err == ECONNREFUSED;
    if (err == EACCES || err == EPERM) {
      error += " (the socket, mode 0660, is for the service's user and group: ask to join that group)";
      kind = Errc::kPermissionDenied;
    }
    return failed();
  }
  const std::string out = line + "\n";
  if (::send(fd, out.data(), out.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(out.size())) {
    error = std::string("sending the request: ") + std::strerror(errno);
    ::close(fd);
    return failed();
  }
  std::string answer;
  char buf[4096];
  while (answer.find('\n') == std::string::npos) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n < 0 && errno == EAGAIN) kind = Errc::kTimeout;
      if (n < 0) error = std::string("reading the answer: ") +
                         (errno == EAGAIN ? "no answer within " + std::to_string(timeout_ms) + " ms"
                                          : std::string(std::strerror(errno)));
      break;
    }
    answer.append(buf, static_cast<std::size_t>(n));
    if (answer.size() > (64u << 20)) {
      error = "answer larger than 64 MiB";
      break;
    }
  }
  ::close(fd);
  const auto nl = answer.find('\n');
  if (nl == std::string::npos) {
    if (error.empty()) error = "the daemon closed the connection without an answer";
    return failed();
  }
  answer.resize(nl);
  return answer;
}

}  // namespace cobridge::cli
