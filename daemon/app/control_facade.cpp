#include "app/control_facade.hpp"

#include "sys/logging.hpp"

#include <unistd.h>

#include <utility>

namespace cobridge::app {

ControlFacade::ControlFacade(const config::Config& cfg, BusSet& buses, const outputs::OutputPipeline& outputs,
                             std::string version, const FlightRecorders* recorders,
                             const bus::StateStore* state)
    : config_(&cfg), buses_(buses), outputs_(outputs), version_(std::move(version)), recorders_(recorders),
      state_(state), started_(std::chrono::system_clock::now()) {}

void ControlFacade::set_config(const config::Config& cfg) {
  const std::lock_guard lock(mutex_);
  config_ = &cfg;
}

void ControlFacade::set_ready() {
  const std::lock_guard lock(mutex_);
  ready_ = true;
}

control::StatusReport ControlFacade::status() {
  const std::lock_guard lock(mutex_);
  control::StatusReport r;
  r.gateway_id = config_->gateway.id;
  r.version = version_;
  r.pid = static_cast<long>(::getpid());
  r.ready = ready_;
  r.started = started_;
  r.config_file = config_->source.string();
  const auto now = std::chrono::steady_clock::now();
  const auto wall = std::chrono::system_clock::now();
  for (std::size_t i = 0; i < buses_.size(); ++i) {
    bus::BusStatus s = buses_[i].status();
    outputs_.add_live_status(i, s, now, wall);
    r.buses.push_back(std::move(s));
  }
  r.outputs = outputs_.output_stats();
  return r;
}

Result<std::vector<std::string>> ControlFacade::commission(std::string_view bus) {
  const std::lock_guard lock(mutex_);
  if (const std::string hold = state_ != nullptr ? state_->hold() : std::string(); !hold.empty()) {
    sys::logger("gateway")->warn("control socket: commissioning refused: the state file is held");
    return Error(Errc::kUnavailable, "commissioning refused: " + hold);
  }
  std::vector<std::string> acted_on;
  for (std::size_t i = 0; i < buses_.size(); ++i) {
    const auto& name = config_->buses[i].name;
    if (!bus.empty() && name != bus) continue;
    buses_[i].request_commission();
    acted_on.push_back(name);
  }
  if (acted_on.empty()) {
    std::string names;
    for (const auto& b : config_->buses) names += (names.empty() ? "" : ", ") + b.name;
    return Error(Errc::kNotFound, "unknown bus \"" + std::string(bus) + "\" (buses: " + names + ")");
  }
  sys::logger("gateway")->info("control socket: commissioning requested on {}", bus.empty() ? "every bus" : bus);
  return acted_on;
}

Result<std::vector<std::string>> ControlFacade::capture_now(std::string_view bus) {
  const std::lock_guard lock(mutex_);
  std::vector<std::string> asked;
  std::vector<std::string> refused;  // the budget of the hour used up (or the writer stuck)
  const auto now = std::chrono::duration_cast<std::chrono::nanoseconds>(
                       std::chrono::system_clock::now().time_since_epoch()).count();
  bool named = bus.empty();
  for (std::size_t i = 0; i < config_->buses.size(); ++i) {
    const auto& b = config_->buses[i];
    if (!bus.empty() && b.name != bus && b.interface != bus) continue;
    named = true;
    bus::CaptureWriter* w = recorders_ ? recorders_->captures(i) : nullptr;
    if (w == nullptr) continue;
    (w->request("operator", {}, now).empty() ? refused : asked).push_back(b.name);
  }
  const std::string where = bus.empty() ? std::string("every bus") : "bus \"" + std::string(bus) + "\"";
  if (!named) return Error(Errc::kNotFound, "unknown bus \"" + std::string(bus) + "\"");
  if (asked.empty() && !refused.empty())
    return Error(Errc::kUnavailable,
                 "no capture: this hour's capture_budget_per_hour is used up, or the writer is 16 captures behind",
                 where);
  if (asked.empty()) return Error(Errc::kUnavailable, "the flight recorder is off (recorder_seconds = 0)", where);
  sys::logger("gateway")->info("control socket: capture requested on {}", where);
  return asked;
}

Result<std::vector<std::string>> ControlFacade::acknowledge(std::string_view device, const std::string& caller) {
  const std::lock_guard lock(mutex_);
  const auto statuses = buses_.statuses();
  for (std::size_t i = 0; i < statuses.size() && i < buses_.size(); ++i) {
    for (const auto& d : statuses[i].devices) {
      if (d.name != device) continue;
      if (bus::contested_count(d) == 0)
        return Error(Errc::kInvalidArgument, "nothing of its configuration is contested", "device "" + d.name + """);
      buses_[i].acknowledge_contested(d.name, caller);
      return std::vector<std::string>{statuses[i].name};
    }
  }
  return Error(Errc::kNotFound, "unknown device "" + std::string(device) + "" (cobridge status lists them)");
}

Result<std::string> ControlFacade::read_capture(std::string_view name) {
  const std::lock_guard lock(mutex_);
  for (std::size_t i = 0; i < config_->buses.size(); ++i) {
    const bus::CaptureWriter* w = recorders_ ? recorders_->captures(i) : nullptr;
    if (w == nullptr) continue;
    // Only a name the writer lists: nothing outside the captures directory.
    Result<std::string> text = w->read(name);
    if (text.ok() || text.error().kind != Errc::kNotFound) return text;
  }
  return Error(Errc::kNotFound, "no capture \"" + std::string(name) + "\" (cobridge capture list shows them)");
}

}  // namespace cobridge::app
