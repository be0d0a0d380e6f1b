// BusController: device states, the status board (steps, problems),
// readiness, and the status published to other threads. Control thread only.
#include "bus/bus_controller.hpp"

namespace cobridge::bus {

namespace {

// Why a device usually enters `s`, when the caller gave no reason.
const char* usual_reason(DeviceState s) {
  switch (s) {
    case DeviceState::identified: return "identified (0x1018)";
    case DeviceState::commissioning: return "being given its node-ID (LSS)";
    case DeviceState::configuring: return "configuration plan started";
    case DeviceState::operational: return "configured and started";
    case DeviceState::offline: return "silent";
    default: return "";
  }
}

}  // namespace

void BusController::set_state(DeviceAgent& m, DeviceState s, std::string why) {
  if (m.st.state == s) return;
  if (why.empty()) why = m.st.last_error;
  if (why.empty()) why = usual_reason(s);
  add_event(m, TimelineKind::state,
            std::string(to_string(m.st.state)) + " -> " + to_string(s) + (why.empty() ? "" : ": " + why));
  m.st.state = s;
  m.st.since = wall_now();
  dirty = true;
  notify(m);
}

void BusController::notify(const DeviceAgent& m) {
  if (options.observer != nullptr) options.observer->on_device_status(m.st);
}

void BusController::add_step(StepTiming t) {
  if (t.at == WallTime{}) t.at = wall_now();
  board.add_step(std::move(t));
  dirty = true;
}

void BusController::add_problem(const std::string& text, const std::string& device, std::uint8_t clash_node) {
  if (board.add_problem(text, device, clash_node)) dirty = true;
}

void BusController::update_ready(TimePoint now) {
  if (ready_latched.load()) return;
  bool all = true;
  for (const auto& m : devices) {
    if (m.in_config && m.st.state != DeviceState::operational) all = false;
  }
  // A standby is ready once it knows the master: the devices are the master's to bring up.
  const bool standing_by = election && election->role() == canopen::MasterRole::standby;
  if (all || standing_by || now - started_at >= options.ready_timeout) {
    if (!all && !standing_by) log->warn("bus {}: ready after {} ms with devices not operational", bus.name,
                        options.ready_timeout.count());
    ready_latched.store(true);
  }
}

void BusController::publish_if_dirty() {
  if (!dirty) return;
  dirty = false;
  publish_all();
}

void BusController::publish_all() {
  BusStatus s;
  s.name = bus.name;
  s.interface = bus.interface;
  s.last_bus_event = live_bus_event;
  s.controller = controller;
  s.devices.reserve(devices.size());
  for (const auto& m : devices) s.devices.push_back(standby() ? m.as_the_bus_says() : m.st);
  s.steps = board.steps();
  // The state file first: while it is held no node-ID is assigned, and an
  // operator must decide (docs/operations.md).
  if (!state_hold.empty()) s.problems.push_back(state_hold);
  for (const auto& p : board.problems()) s.problems.push_back(p.text);
  describe_role(s);
  const std::lock_guard lock(mutex);
  published = std::move(s);
}

}  // namespace cobridge::bus
