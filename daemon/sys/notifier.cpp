#include "sys/notifier.hpp"

#include <systemd/sd-daemon.h>

#include <cstdlib>
#include <ctime>
#include <string>

namespace cobridge::sys {

Notifier::Notifier() {
  const char* socket = std::getenv("NOTIFY_SOCKET");
  enabled_ = socket != nullptr && socket[0] != '\0';
  uint64_t usec = 0;
  // sd_watchdog_enabled checks WATCHDOG_PID against our pid, so a forked
  // helper never pings in the daemon's name.
  if (enabled_ && sd_watchdog_enabled(0, &usec) > 0 && usec > 0)
    watchdog_period_ = std::chrono::microseconds(static_cast<int64_t>(usec / 2));
}

std::error_code Notifier::send(std::string_view message) {
  if (!enabled_) return {};
  const std::string text(message);
  const int rc = sd_notify(0, text.c_str());
  if (rc < 0) return {-rc, std::system_category()};
  return {};
}

std::error_code Notifier::ready() { return send("READY=1"); }

std::error_code Notifier::status(std::string_view text) {
  std::string m = "STATUS=";
  m.append(text);
  return send(m);
}

std::error_code Notifier::watchdog() { return send("WATCHDOG=1"); }

std::error_code Notifier::reloading() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  const auto usec = static_cast<unsigned long long>(ts.tv_sec) * 1000000ULL +
                    static_cast<unsigned long long>(ts.tv_nsec) / 1000ULL;
  return send("RELOADING=1\nMONOTONIC_USEC=" + std::to_string(usec));
}

std::error_code Notifier::stopping() { return send("STOPPING=1"); }

}  // namespace cobridge::sys
