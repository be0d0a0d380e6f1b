// BusController: the bus's health beyond its devices. The CAN
// controller's state and counters come over netlink once a second (the
// shell reads them, can/controller_netlink; the error frames feed the same
// ControllerHealth in bus_controller_frames.cpp), and the bus's health goes
// to the observer (the outputs: plugin ABI 5 on_bus) through BusHealthGate.
// Control thread only.
#include "bus/bus_controller.hpp"

namespace cobridge::bus {

TimePoint BusController::watch_health(TimePoint now) {
  tell_health(now);
  return health_gate.next();
}

void BusController::on_netlink(const Result<can::NetlinkReading>& reading) {
  if (!reading.ok()) {
    // A missing interface is the channel's news (it waits and reopens);
    // here one line per run of failures says the figures are not current.
    if (!netlink_failing)
      log->warn("bus {}: CAN controller state not read over netlink: {} ({})", bus.name, reading.error().message,
                reading.error().where);
    netlink_failing = true;
    if (controller.driver != can::DriverReport::failed) dirty = true;
    controller.driver = can::DriverReport::failed;
    return;
  }
  netlink_failing = false;
  const can::ControllerHealth before = controller;
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(wall_now().time_since_epoch()).count();
  if (can::apply_netlink(controller, *reading, ns)) {
    // The first state a healthy adapter reports at start is news, not a
    // fault: info for it and for a return to error-active, warn otherwise.
    const bool news_only = before.state == can::ControllerState::unknown ||
                           controller.state == can::ControllerState::error_active;
    log->log(news_only ? spdlog::level::info : spdlog::level::warn, "bus {}: CAN controller {} -> {} (netlink{})",
             bus.name, can::to_string(before.state), can::to_string(controller.state),
             controller.counters_known
                 ? fmt::format(": tx errors {}, rx errors {}", controller.tx_errors, controller.rx_errors)
                 : std::string());
    if (!news_only || before.state != can::ControllerState::unknown) {
      add_bus_event(TimelineKind::controller,
                    "CAN controller " + std::string(can::to_string(before.state)) + " -> " +
                        std::string(can::to_string(controller.state)) + " (netlink)",
                    news_only ? std::string() : capture("bus error", {}));
    }
  }
  if (before.driver != controller.driver && controller.driver == can::DriverReport::no_state)
    log->info("bus {}: {} reports no CAN controller state over netlink (not a can-dev driver, e.g. vcan); "
              "controller health from error frames only", bus.name, bus.interface);
  if (before.driver != controller.driver || before.state != controller.state || before.source != controller.source ||
      before.tx_errors != controller.tx_errors || before.rx_errors != controller.rx_errors)
    dirty = true;
}

void BusController::tell_health(TimePoint now) {
  if (options.observer == nullptr) return;
  BusHealth h;
  h.open = channel->is_open();
  h.controller = controller;
  h.error_frames = channel->stats().error_frames;
  if (health_gate.due(h, now)) options.observer->on_bus_health(h);
}

}  // namespace cobridge::bus
