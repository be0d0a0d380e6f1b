// BusController as the ServiceGate: what clients' SDO / NMT / LSS
// commands may do now, and what they did. Control thread only.
#include "bus/bus_controller.hpp"

#include <utility>

namespace cobridge::bus {

bool BusController::node_free(std::uint8_t node) const {
  if (discovery->commissioning() || !channel->is_open()) return false;
  for (const auto& m : devices) {
    if (node != 0 && m.st.node_id != node) continue;
    if (m.runner || m.ident || m.command) return false;
    const auto s = m.st.state;
    if (s == DeviceState::identified || s == DeviceState::configuring || s == DeviceState::commissioning) return false;
    if (m.want_configure && s != DeviceState::failed) return false;
  }
  return true;
}

bool BusController::node_supervised(std::uint8_t node) const {
  return std::any_of(devices.begin(), devices.end(),
                     [&](const DeviceAgent& m) { return m.in_config && m.st.node_id == node && m.description != nullptr; });
}

void BusController::on_nmt_sent(canopen::NmtCommand command, std::uint8_t node, const std::string& caller) {
  const bool hold = command == canopen::NmtCommand::stop || command == canopen::NmtCommand::enter_preop;
  for (auto& m : devices) {
    if (!m.in_config || (node != 0 && m.st.node_id != node)) continue;
    const bool held = std::exchange(m.operator_hold, hold);
    if (hold) {
      m.st.last_error = "left " + std::string(command == canopen::NmtCommand::stop ? "stopped" : "pre-operational") +
                        " by a client's NMT command (" + caller + ")";
      set_state(m, DeviceState::stopped);
    } else if (held && m.started && command == canopen::NmtCommand::start && m.st.state == DeviceState::stopped &&
               supervisor.nmt(m.st.node_id) == canopen::NmtState::operational) {
      // Started again before any heartbeat showed it stopped: the heartbeat
      // never changes, so no NMT state change will tell; it runs as it did.
      log->info("bus {}: device {} (node {}) is operational again (a client's NMT start)", bus.name, m.st.name,
                m.st.node_id);
      m.st.last_error.clear();
      set_state(m, m.st.online ? DeviceState::operational : DeviceState::offline);
    }
    // A restore held back while the client had the device stopped.
    if (command == canopen::NmtCommand::start && !m.st.drift.empty() &&
        m.cfg.on_config_drift == config::DriftPolicy::restore)
      restore_configuration(m, steady_now(), steady_now());
  }
}

void BusController::on_lss_node_id(const canopen::LssAddress& device, std::uint8_t node, bool stored) {
  log->info("bus {}: a client set serial {} to node-ID {}{}", bus.name, device.serial, node,
            stored ? " (stored)" : " (not stored)");
  if (!stored) return;
  DiscoveryEvent e;
  e.kind = DiscoveryEventKind::commissioned;
  e.node_id = node;
  e.previous_node_id = canopen::cob::kNodeIdUnconfigured;
  e.identity = device;
  if (const Error err = record_assignment(state, bus.name, e))
    log->error("bus {}: state file {}", bus.name, err.to_string());
}

}  // namespace cobridge::bus
