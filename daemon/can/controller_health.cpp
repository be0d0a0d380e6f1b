#include "can/controller_health.hpp"

namespace cobridge::can {

std::string_view to_string(ControllerState s) noexcept {
  switch (s) {
    case ControllerState::error_active: return "error-active";
    case ControllerState::error_warning: return "error-warning";
    case ControllerState::error_passive: return "error-passive";
    case ControllerState::bus_off: return "bus-off";
    case ControllerState::unknown: return "unknown";
  }
  return "?";
}

std::string_view to_string(HealthSource s) noexcept {
  switch (s) {
    case HealthSource::none: return "none";
    case HealthSource::error_frames: return "error frames";
    case HealthSource::netlink: return "netlink";
  }
  return "?";
}

namespace {

// The state an event announces, if it announces one.
bool state_of(BusEventKind kind, ControllerState& out) noexcept {
  switch (kind) {
    case BusEventKind::ErrorActive:
    case BusEventKind::Restarted: out = ControllerState::error_active; return true;
    case BusEventKind::ErrorWarning: out = ControllerState::error_warning; return true;
    case BusEventKind::ErrorPassive: out = ControllerState::error_passive; return true;
    case BusEventKind::BusOff: out = ControllerState::bus_off; return true;
    default: return false;
  }
}

}  // namespace

bool ControllerHealth::set_state(ControllerState next, std::int64_t at_ns) noexcept {
  if (next == state) return false;
  state = next;
  since_ns = at_ns;
  return true;
}

bool ControllerHealth::apply(const BusEvent& ev) noexcept {
  ControllerState next = state;
  const bool tells_state = state_of(ev.kind, next);
  // Netlink, once it answered, stays the source: frames only refresh its
  // figures between two polls.
  if ((tells_state || ev.has_counters) && source == HealthSource::none) source = HealthSource::error_frames;
  if (ev.has_counters) {
    counters_known = true;
    tx_errors = ev.tx_error_count;
    rx_errors = ev.rx_error_count;
  }
  if (ev.kind == BusEventKind::Restarted) ++restarts;
  if (ev.kind == BusEventKind::ProtocolViolation || ev.kind == BusEventKind::AckMissing ||
      ev.kind == BusEventKind::Transceiver || ev.kind == BusEventKind::BusError)
    ++bus_errors;
  return tells_state && set_state(next, ev.timestamp_ns);
}

}  // namespace cobridge::can
