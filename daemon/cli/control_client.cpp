#include "cli/control_client.hpp"

#include <sys/socket.h>
#include <sys/time.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace cobridge::cli {

namespace {

// What went wrong, for request() to turn into its Error.
struct Failure {
  std::string message;
  Errc kind = Errc::kUnavailable;
};

// A connected socket with send and receive timeouts, or -1 with `why` set.
int connect_to(const std::string& path, int timeout_ms, Failure& why, bool* no_daemon) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof addr.sun_path) {
    why.message = "control socket path \"" + path + "\" is empty or too long";
    return -1;
  }
  path.copy(addr.sun_path, path.size());
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    why.message = std::string("socket: ") + std::strerror(errno);
    return -1;
  }
  timeval tv{timeout_ms / 1000, static_cast<suseconds_t>((timeout_ms % 1000) * 1000)};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    const int err = errno;
    ::close(fd);
    why.message = "cannot reach cobridged at " + path + ": " + std::strerror(err);
    if (err == ENOENT || err == ECONNREFUSED) why.message += " (is cobridged running? see --control)";
    if (no_daemon != nullptr) *no_daemon = err == ENOENT || err == ECONNREFUSED;
    if (err == EACCES || err == EPERM) {
      why.message += " (the socket, mode 0660, is for the service's user and group: ask to join that group)";
      why.kind = Errc::kPermissionDenied;
    }
    return -1;
  }
  return fd;
}

// Reads up to the first newline (or a failure, noted in `why`).
std::string read_answer(int fd, int timeout_ms, Failure& why) {
  std::string answer;
  char buf[4096];
  while (answer.find('\n') == std::string::npos) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n < 0 && errno == EAGAIN) why.kind = Errc::kTimeout;
      if (n < 0) why.message = std::string("reading the answer: ") +
                               (errno == EAGAIN ? "no answer within " + std::to_string(timeout_ms) + " ms"
                                                : std::string(std::strerror(errno)));
      break;
    }
    answer.append(buf, static_cast<std::size_t>(n));
    if (answer.size() > (64u << 20)) {
      why.message = "answer larger than 64 MiB";
      break;
    }
  }
  return answer;
}

}  // namespace

std::optional<std::string> request(const std::string& path, const std::string& line, int timeout_ms,
                                   Error& failure, bool* no_daemon) {
  failure = {};
  Failure why;
  const auto failed = [&]() -> std::optional<std::string> {
    failure = Error(why.kind, why.message);
    return std::nullopt;
  };
  if (no_daemon != nullptr) *no_daemon = false;
  const int fd = connect_to(path, timeout_ms, why, no_daemon);
  if (fd < 0) return failed();
  const std::string out = line + "\n";
  if (::send(fd, out.data(), out.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(out.size())) {
    why.message = std::string("sending the request: ") + std::strerror(errno);
    ::close(fd);
    return failed();
  }
  std::string answer = read_answer(fd, timeout_ms, why);
  ::close(fd);
  const auto nl = answer.find('\n');
  if (nl == std::string::npos) {
    if (why.message.empty()) why.message = "the daemon closed the connection without an answer";
    return failed();
  }
  answer.resize(nl);
  return answer;
}

}  // namespace cobridge::cli
