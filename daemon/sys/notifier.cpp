#include "sys/notifier.hpp"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <string>

namespace cobridge::sys {
namespace {

// The whole value of an environment variable as an unsigned number.
bool env_number(const char* name, unsigned long long& out) {
  const char* text = std::getenv(name);
  if (text == nullptr || text[0] == '\0') return false;
  const char* end = text + std::strlen(text);
  const auto r = std::from_chars(text, end, out);
  return r.ec == std::errc() && r.ptr == end;
}

}  // namespace

Error notify_datagram(std::string_view address, std::string_view message) {
  const auto failed = [address](const char* what, std::error_code ec) {
    return Error(Errc::kUnavailable, what + (": " + ec.message()), "notify socket " + std::string(address), ec);
  };
  // sd_notify(3): "/path" is a file system socket, "@name" an abstract one.
  if (address.empty() || (address[0] != '/' && address[0] != '@'))
    return failed("not a path or @name", std::make_error_code(std::errc::address_family_not_supported));
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (address.size() >= sizeof addr.sun_path)
    return failed("too long", std::make_error_code(std::errc::filename_too_long));
  std::memcpy(addr.sun_path, address.data(), address.size());
  if (address[0] == '@') addr.sun_path[0] = '\0';
  // A file system path is NUL-terminated; an abstract name is exactly its bytes.
  const auto len = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + address.size() + (address[0] == '/' ? 1 : 0));
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return failed("socket", std::error_code(errno, std::system_category()));
  const ssize_t n = ::sendto(fd, message.data(), message.size(), MSG_NOSIGNAL, reinterpret_cast<const sockaddr*>(&addr), len);
  const int err = errno;
  ::close(fd);
  if (n < 0) return failed("sendto", std::error_code(err, std::system_category()));
  return {};
}

Notifier::Notifier() {
  const char* socket = std::getenv("NOTIFY_SOCKET");
  enabled_ = socket != nullptr && socket[0] != '\0';
  if (enabled_) socket_ = socket;
  // As sd_watchdog_enabled(3): WATCHDOG_PID, when set, must be our pid, so a
  // forked helper never pings in the daemon's name.
  unsigned long long usec = 0;
  unsigned long long pid = 0;
  const bool ours = std::getenv("WATCHDOG_PID") == nullptr ||
                    (env_number("WATCHDOG_PID", pid) && pid == static_cast<unsigned long long>(::getpid()));
  if (enabled_ && ours && env_number("WATCHDOG_USEC", usec) && usec > 0)
    watchdog_period_ = std::chrono::microseconds(static_cast<int64_t>(usec / 2));
}

Error Notifier::send(std::string_view message) {
  if (!enabled_) return {};
  return notify_datagram(socket_, message);
}

Error Notifier::ready() { return send("READY=1"); }

Error Notifier::status(std::string_view text) {
  std::string m = "STATUS=";
  m.append(text);
  return send(m);
}

Error Notifier::watchdog() { return send("WATCHDOG=1"); }

Error Notifier::reloading() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  const auto usec = static_cast<unsigned long long>(ts.tv_sec) * 1000000ULL +
                    static_cast<unsigned long long>(ts.tv_nsec) / 1000ULL;
  return send("RELOADING=1\nMONOTONIC_USEC=" + std::to_string(usec));
}

Error Notifier::stopping() { return send("STOPPING=1"); }

}  // namespace cobridge::sys
