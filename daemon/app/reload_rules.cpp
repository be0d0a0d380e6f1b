#include "app/reload_rules.hpp"

#include <cstddef>

namespace cobridge::app {
namespace {

// A reload keeps the buses open, so it may change what is on them, not which
// buses there are.
std::string bus_change(const config::Config& running, const config::Config& next) {
  if (running.buses.size() != next.buses.size()) return "the number of [[bus]] tables changed";
  for (std::size_t i = 0; i < running.buses.size(); ++i) {
    if (running.buses[i].name != next.buses[i].name || running.buses[i].interface != next.buses[i].interface)
      return "bus " + running.buses[i].name + " (" + running.buses[i].interface + ") became " + next.buses[i].name +
             " (" + next.buses[i].interface + ")";
    // The flight recorder's ring is allocated at start, and its writer made then.
    const auto& a = running.buses[i];
    const auto& b = next.buses[i];
    if (a.recorder_seconds != b.recorder_seconds || a.capture_after_ms != b.capture_after_ms ||
        a.capture_cap_mib != b.capture_cap_mib || a.capture_budget_per_hour != b.capture_budget_per_hour)
      return "bus " + a.name + ": the flight recorder's settings (recorder_seconds, capture_after_s, "
             "capture_cap_mib, capture_budget_per_hour) take a restart";
  }
  return {};
}

// The plugins run with the settings they were created with: a reload that
// changes an output is refused rather than half applied.
std::string outputs_change(const config::Config& running, const config::Config& next) {
  if (running.outputs.size() != next.outputs.size()) return "the [outputs.*] tables changed";
  for (std::size_t i = 0; i < running.outputs.size(); ++i) {
    const auto& a = running.outputs[i];
    const auto& b = next.outputs[i];
    if (a.name != b.name || a.enabled != b.enabled || a.plugin != b.plugin || a.settings_toml != b.settings_toml)
      return "[outputs." + a.name + "] changed";
  }
  return {};
}

// The web service runs with the settings it was started with.
bool web_change(const config::Config& running, const config::Config& next) {
  const auto& a = running.web;
  const auto& b = next.web;
  if (a.has_value() != b.has_value()) return true;
  if (!a) return false;
  return a->enabled != b->enabled || a->bind != b->bind || a->port != b->port || a->tls_cert != b->tls_cert ||
         a->tls_key != b->tls_key || a->auth_file != b->auth_file || a->max_clients != b->max_clients ||
         a->timeout_s != b->timeout_s || a->hosts != b->hosts;
}

}  // namespace

std::string reload_refusal(const config::Config& running, const config::Config& next) {
  std::string refusal = bus_change(running, next);
  if (refusal.empty() && next.gateway.state_dir != running.gateway.state_dir) refusal = "gateway.state_dir changed";
  if (refusal.empty() && next.gateway.control_socket != running.gateway.control_socket)
    refusal = "gateway.control_socket changed";
  if (refusal.empty() && web_change(running, next)) refusal = "[web] changed";
  if (refusal.empty()) refusal = outputs_change(running, next);
  return refusal;
}

}  // namespace cobridge::app
