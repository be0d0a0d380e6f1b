// What systemd hears from the daemon while it runs: READY=1 once every bus is
// ready, STATUS= whenever the one-line summary changes (with the news of a
// rejected reload), WATCHDOG=1 while every bus's control thread is alive,
// RELOADING=1 around a reload and STOPPING=1 at the end.
//
// Time is passed in, like every component the main loop drives: tick(now)
// does what is due and next_deadline() says when it is next due.
//
// Thread: the main thread only.
#pragma once

#include "app/bus_set.hpp"
#include "app/control_facade.hpp"
#include "sys/notifier.hpp"

#include <chrono>
#include <string>

namespace cobridge::app {

class ServiceStatus {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr std::chrono::milliseconds kTick{100};  // READY / STATUS checks

  ServiceStatus(sys::Notifier& notifier, const BusSet& buses, ControlFacade& facade);

  [[nodiscard]] Clock::time_point next_deadline() const noexcept;
  void tick(Clock::time_point now);

  void reloading();
  // After a reload, accepted (`note` empty) or rejected (`note` is appended
  // to STATUS= until the next accepted one).
  void reloaded(std::string note);
  void stopping();

 private:
  void check_ready_and_status();

  sys::Notifier& notifier_;
  const BusSet& buses_;
  ControlFacade& facade_;
  bool ready_ = false;
  std::string last_status_;
  std::string reload_note_;
  Clock::duration watchdog_period_;
  Clock::time_point next_watchdog_;
  Clock::time_point next_tick_;
};

}  // namespace cobridge::app
