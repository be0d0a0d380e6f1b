#include "app/control_channel.hpp"

#include <fcntl.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace cobridge::sim {

ControlChannel::~ControlChannel() {
  for (Client& c : clients_) ::close(c.fd);
  if (listen_fd_ >= 0) {
    ::close(listen_fd_);
    std::error_code ec;
    std::filesystem::remove(path_, ec);
  }
}

Error ControlChannel::listen(const std::filesystem::path& path) {
  const auto failed = [&path](std::error_code ec) { return Error(Errc::kFailed, ec.message(), path.string(), ec); };
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  const std::string p = path.string();
  if (p.empty() || p.size() >= sizeof addr.sun_path) return failed(std::make_error_code(std::errc::filename_too_long));
  std::memcpy(addr.sun_path, p.c_str(), p.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) return failed(std::error_code(errno, std::generic_category()));
  std::error_code ec;
  if (std::filesystem::is_socket(path, ec)) std::filesystem::remove(path, ec);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0 || ::listen(fd, 16) != 0) {
    const int err = errno;
    ::close(fd);
    return failed(std::error_code(err, std::generic_category()));
  }
  listen_fd_ = fd;
  path_ = path;
  return {};
}

void ControlChannel::watch_input(int fd, int reply_fd) noexcept {
  input_.fd = fd;
  reply_fd_ = reply_fd;
}

void ControlChannel::append_poll_fds(std::vector<pollfd>& fds) {
  poll_base_ = fds.size();
  if (input_.fd >= 0) fds.push_back(pollfd{input_.fd, POLLIN, 0});
  if (listen_fd_ >= 0) fds.push_back(pollfd{listen_fd_, POLLIN, 0});
  for (const Client& c : clients_) fds.push_back(pollfd{c.fd, POLLIN, 0});
  poll_count_ = fds.size() - poll_base_;
}

bool ControlChannel::write_all(int fd, std::string_view data) noexcept {
  while (!data.empty()) {
    const ssize_t n = ::send(fd, data.data(), data.size(), MSG_NOSIGNAL);
    if (n < 0 && errno == ENOTSOCK) {
      const ssize_t w = ::write(fd, data.data(), data.size());
      if (w < 0 && errno == EINTR) continue;
      if (w <= 0) return false;
      data.remove_prefix(static_cast<std::size_t>(w));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) {
      pollfd p{fd, POLLOUT, 0};
      if (::poll(&p, 1, 1000) <= 0) return false;  // a client that does not read loses its reply
      continue;
    }
    if (n <= 0) return false;
    data.remove_prefix(static_cast<std::size_t>(n));
  }
  return true;
}

void ControlChannel::handle_lines(Client& c, const Handler& handler, int reply_fd) {
  std::size_t start = 0;
  for (;;) {
    const std::size_t nl = c.pending.find('\n', start);
    if (nl == std::string::npos) break;
    std::string reply = handler(std::string_view(c.pending).substr(start, nl - start));
    reply += '\n';
    write_all(reply_fd, reply);
    start = nl + 1;
  }
  c.pending.erase(0, start);
  if (c.pending.size() > kMaxLineBytes) {
    c.pending.clear();
    write_all(reply_fd, "error line too long\n");
  }
}

void ControlChannel::service(const std::vector<pollfd>& fds, const Handler& handler) {
  const std::size_t end = std::min(fds.size(), poll_base_ + poll_count_);
  bool accept_ready = false;
  std::vector<int> closed;
  for (std::size_t i = poll_base_; i < end; ++i) {
    const pollfd& p = fds[i];
    if (p.revents == 0) continue;
    if (p.fd == listen_fd_) {
      accept_ready = true;
      continue;
    }
    Client* c = p.fd == input_.fd ? &input_ : nullptr;
    for (Client& cl : clients_)
      if (cl.fd == p.fd) c = &cl;
    if (c == nullptr) continue;
    char buf[1024];
    const ssize_t n = ::read(c->fd, buf, sizeof buf);
    if (n > 0) {
      c->pending.append(buf, static_cast<std::size_t>(n));
      handle_lines(*c, handler, c == &input_ ? reply_fd_ : c->fd);
    } else if (n == 0 || (errno != EAGAIN && errno != EINTR)) {
      closed.push_back(c->fd);
    }
  }
  for (const int fd : closed) {
    if (fd == input_.fd) {
      input_.fd = -1;  // end of stdin: keep running
      continue;
    }
    for (std::size_t k = 0; k < clients_.size(); ++k) {
      if (clients_[k].fd != fd) continue;
      ::close(fd);
      clients_.erase(clients_.begin() + static_cast<std::ptrdiff_t>(k));
      break;
    }
  }
  if (accept_ready) {
    for (;;) {
      const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
      if (fd < 0) break;
      clients_.push_back(Client{fd, {}});
    }
  }
}

}  // namespace cobridge::sim
