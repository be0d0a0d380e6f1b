#include "app/service_status.hpp"

#include "sys/logging.hpp"

#include <algorithm>
#include <utility>
#include <vector>

namespace cobridge::app {

ServiceStatus::ServiceStatus(sys::Notifier& notifier, const BusSet& buses, ControlFacade& facade)
    : notifier_(notifier), buses_(buses), facade_(facade),
      watchdog_period_(std::chrono::duration_cast<Clock::duration>(notifier.watchdog_period())),
      next_watchdog_(Clock::now()), next_tick_(Clock::now()) {
  if (watchdog_period_.count() > 0)
    sys::logger("gateway")->info("systemd watchdog: pinging every {} ms while every bus is served",
                                 std::chrono::duration_cast<std::chrono::milliseconds>(watchdog_period_).count());
}

ServiceStatus::Clock::time_point ServiceStatus::next_deadline() const noexcept {
  return watchdog_period_.count() > 0 ? std::min(next_tick_, next_watchdog_) : next_tick_;
}

void ServiceStatus::tick(Clock::time_point now) {
  if (now >= next_tick_) {
    next_tick_ = now + kTick;
    check_ready_and_status();
  }
  if (watchdog_period_.count() > 0 && now >= next_watchdog_) {
    next_watchdog_ = now + watchdog_period_;
    // Every bus's control thread alive; an absent adapter is in STATUS=, not a reason to be restarted.
    if (buses_.serving()) (void)notifier_.watchdog();
  }
}

void ServiceStatus::check_ready_and_status() {
  auto log = sys::logger("gateway");
  if (!ready_ && buses_.ready()) {
    ready_ = true;
    facade_.set_ready();
    (void)notifier_.ready();
    log->info("ready");
  }
  const std::string text = control::summary(buses_.statuses()) + reload_note_;
  if (text != last_status_) {
    (void)notifier_.status(text);
    if (ready_) log->info("{}", text);
    last_status_ = text;
  }
}

void ServiceStatus::reloading() { (void)notifier_.reloading(); }

void ServiceStatus::reloaded(std::string note) {
  reload_note_ = std::move(note);
  last_status_.clear();  // tell STATUS= again after RELOADING
  // Before the first READY=1 the tick still sends it.
  if (ready_) (void)notifier_.ready();
}

void ServiceStatus::stopping() { (void)notifier_.stopping(); }

}  // namespace cobridge::app
