#include "control/line_connection.hpp"

#include "sys/logging.hpp"

#include <sys/socket.h>
#include <sys/types.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <system_error>

namespace cobridge::control {

void LineConnection::read(std::size_t max_line) {
  std::array<char, 1024> buf{};
  while (!has_line() && in.size() <= max_line) {
    const std::size_t room = std::min(buf.size(), max_line + 1 - in.size());
    const ssize_t n = ::recv(fd, buf.data(), room, MSG_DONTWAIT);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return;
    if (n <= 0) {
      peer_closed = true;
      return;
    }
    std::string_view chunk(buf.data(), static_cast<std::size_t>(n));
    if (skipping) {
      const auto nl = chunk.find('\n');
      if (nl == std::string_view::npos) continue;
      chunk.remove_prefix(nl + 1);
      skipping = false;
    }
    in.append(chunk);
  }
}

std::string LineConnection::take_line() {
  const std::size_t nl = in.find('\n');
  std::string line(line_body(std::string_view(in).substr(0, nl + 1)));
  in.erase(0, nl + 1);
  return line;
}

std::string_view line_body(std::string_view line) noexcept {
  if (!line.empty() && line.back() == '\n') line.remove_suffix(1);
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return line;
}

bool LineConnection::flush() {
  while (out_done < out.size()) {
    const ssize_t n = ::send(fd, out.data() + out_done, out.size() - out_done, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      out_done += static_cast<std::size_t>(n);
    } else if (n < 0 && errno == EINTR) {
      continue;
    } else {
      return n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK);  // else the client went away
    }
  }
  out.clear();
  out_done = 0;
  return true;
}

int accept_connection(int listen_fd, const char* server, void* peer, unsigned* peer_len) {
  while (true) {
    socklen_t len = peer_len != nullptr ? *peer_len : 0;
    const int fd = ::accept4(listen_fd, static_cast<sockaddr*>(peer), peer != nullptr ? &len : nullptr,
                             SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd >= 0) {
      if (peer_len != nullptr) *peer_len = len;
      return fd;
    }
    if (errno == EINTR || errno == ECONNABORTED) continue;
    if (errno != EAGAIN && errno != EWOULDBLOCK)
      sys::logger("gateway")->warn("{}: accept: {}", server, std::error_code(errno, std::system_category()).message());
    return -1;
  }
}

void refuse_connection(int fd, std::string_view line) {
  (void)::send(fd, line.data(), line.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  ::close(fd);
}

}  // namespace cobridge::control
