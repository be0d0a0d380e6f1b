// Notifier: the daemon's side of the systemd notify protocol (sd_notify(3)).
//
// READY, STATUS, WATCHDOG, RELOADING, STOPPING go to $NOTIFY_SOCKET, one
// datagram each. The protocol is written here rather than linked from
// libsystemd (systemd documents it as stable for reimplementation): the
// library and its compression and crypto chain would be loaded on every start
// for a few datagrams, and each mapped library costs start-up time. Without
// systemd (the variable unset) every call does nothing and succeeds, so the
// daemon runs the same in a terminal. The watchdog interval comes from
// $WATCHDOG_USEC; the caller pings only while its buses are really served.
// Thread: any one thread (the daemon's main loop); not thread-safe.
#pragma once

#include "base/error.hpp"

#include <chrono>
#include <string>
#include <string_view>
#include <system_error>

namespace cobridge::sys {

// One datagram to a notify socket address as $NOTIFY_SOCKET gives it: an
// absolute path, or "@name" for the abstract namespace. Any thread. A failure
// (kUnavailable) has the address as its where and the errno as its code.
Error notify_datagram(std::string_view address, std::string_view message);

class Notifier {
 public:
  Notifier();

  [[nodiscard]] bool enabled() const noexcept { return enabled_; }
  // Half the interval systemd expects pings at, or zero when no watchdog.
  [[nodiscard]] std::chrono::microseconds watchdog_period() const noexcept { return watchdog_period_; }

  Error ready();
  Error status(std::string_view text);
  Error watchdog();
  // RELOADING=1 with MONOTONIC_USEC (systemd >= 253 asks for it; older ones ignore it).
  Error reloading();
  Error stopping();

 private:
  Error send(std::string_view message);
  bool enabled_ = false;
  std::string socket_;
  std::chrono::microseconds watchdog_period_{0};
};

}  // namespace cobridge::sys
