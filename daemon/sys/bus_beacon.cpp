#include "sys/bus_beacon.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <system_error>
#include <utility>

namespace cobridge::sys {
namespace {

// sockaddr_un of the abstract name and its length (no trailing NUL counted).
socklen_t abstract_address(std::string_view iface, sockaddr_un& addr) {
  const std::string name = bus_beacon_name(iface);
  addr = {};
  addr.sun_family = AF_UNIX;
  const std::size_t n = std::min(name.size(), sizeof addr.sun_path - 1);
  std::memcpy(addr.sun_path + 1, name.data(), n);
  return static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + 1 + n);
}

Error system_error(std::string message, std::string where, int err) {
  return Error(Errc::kUnavailable, std::move(message) + ": " + std::strerror(err), std::move(where),
               std::error_code(err, std::generic_category()));
}

// Reads the owner's one line within the deadline; empty on failure.
std::string read_line(int fd, std::chrono::steady_clock::time_point deadline) {
  std::string text;
  char buf[512];
  while (text.find('\n') == std::string::npos && text.size() < 4096) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    pollfd p{fd, POLLIN, 0};
    if (left.count() <= 0 || ::poll(&p, 1, static_cast<int>(left.count())) <= 0) return {};
    const ssize_t r = ::recv(fd, buf, sizeof buf, 0);
    if (r <= 0) return {};
    text.append(buf, static_cast<std::size_t>(r));
  }
  return text.substr(0, text.find('\n'));
}

// "cobridged <pid> <path>" -> BusOwner.
std::optional<BusOwner> parse_owner(const std::string& line) {
  const std::string head = "cobridged ";
  if (line.compare(0, head.size(), head) != 0) return std::nullopt;
  const std::size_t space = line.find(' ', head.size());
  if (space == std::string::npos || space + 1 >= line.size()) return std::nullopt;
  BusOwner o;
  o.pid = static_cast<pid_t>(std::strtol(line.c_str() + head.size(), nullptr, 10));
  o.control = line.substr(space + 1);
  return o;
}

}  // namespace

std::string bus_beacon_name(std::string_view iface) { return "cobridge/bus/" + std::string(iface); }

BusBeacon::~BusBeacon() { close(); }

BusBeacon::BusBeacon(BusBeacon&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)), line_(std::move(other.line_)) {}

BusBeacon& BusBeacon::operator=(BusBeacon&& other) noexcept {
  if (this != &other) {
    close();
    fd_ = std::exchange(other.fd_, -1);
    line_ = std::move(other.line_);
  }
  return *this;
}

Error BusBeacon::open(std::string_view iface, const std::string& control_path) {
  close();
  sockaddr_un addr;
  const socklen_t len = abstract_address(iface, addr);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd < 0) return system_error("bus beacon socket", std::string(iface), errno);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), len) != 0 || ::listen(fd, 8) != 0) {
    const int err = errno;
    ::close(fd);
    if (err != EADDRINUSE) return system_error("bus beacon @" + bus_beacon_name(iface), std::string(iface), err);
    Error found;
    const auto other = find_bus_owner(iface, 500, found);
    return Error(Errc::kUnavailable,
                 "another cobridged serves this interface" +
                     (other ? " (pid " + std::to_string(other->pid) + ", control socket " + other->control + ")"
                            : std::string()),
                 std::string(iface));
  }
  fd_ = fd;
  line_ = "cobridged " + std::to_string(::getpid()) + " " + control_path + "\n";
  return {};
}

void BusBeacon::serve() noexcept {
  while (fd_ >= 0) {
    const int c = ::accept4(fd_, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
    if (c < 0) return;  // EAGAIN: none left (or a transient error: the next poll retries)
    // A fresh connection's buffer takes one short line whole.
    (void)::send(c, line_.data(), line_.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    ::close(c);
  }
}

void BusBeacon::close() noexcept {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

std::optional<BusOwner> find_bus_owner(std::string_view iface, int timeout_ms, Error& error) {
  sockaddr_un addr;
  const socklen_t len = abstract_address(iface, addr);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    error = system_error("bus beacon socket", std::string(iface), errno);
    return std::nullopt;
  }
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), len) != 0) {
    ::close(fd);
    return std::nullopt;  // ECONNREFUSED: nobody listens on that name
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  const std::string line = read_line(fd, deadline);
  ::close(fd);
  auto owner = parse_owner(line);
  if (!owner)
    error = Error(Errc::kUnavailable,
                  "a process listens on @" + bus_beacon_name(iface) + " but did not say which cobridged it is within " +
                      std::to_string(timeout_ms) + " ms",
                  std::string(iface));
  return owner;
}

}  // namespace cobridge::sys
