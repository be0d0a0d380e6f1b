// BusManager::Impl: configuration drift (issue 29 item 4). A client's
// confirmed write (CLI / control socket, CiA 309-3, a plugin's preset, or
// another SDO client on the bus, canopen/sdo_observer.hpp) of
// an object the device's plan sets, to another value, is recorded on the
// device (status "configuration differs"), put on its timeline and logged
// once; then, per the device's on_config_drift, the full plan runs again at
// once (restore) or the operator's value stays until the next plan runs
// (keep). Control thread only.
#include "bus/bus_manager_impl.hpp"
#include "bus/config_drift.hpp"

#include <array>
#include <span>

namespace cobridge::gateway {

void BusManager::Impl::on_sdo_written(const RemoteCommand& c, TimePoint now) {
  for (auto& m : devices) {
    if (m.in_config && m.st.node_id == c.node) note_client_write(m, c.index, c.sub, c.data, c.caller, now);
  }
}

void BusManager::Impl::on_foreign_write(const canopen::ObservedWrite& w, TimePoint now) {
  Managed* m = find_node(w.node);
  if (m == nullptr) return;
  note_client_write(*m, w.index, w.sub, std::span(w.data.data(), w.size),
                    "an SDO client on the bus (not through the gateway)", now);
}

void BusManager::Impl::note_client_write(Managed& m, std::uint16_t index, std::uint8_t sub,
                                         std::span<const std::uint8_t> bytes, const std::string& writer,
                                         TimePoint now) {
  if (!m.plan || standby()) return;
  const DriftCheck check = check_write(*m.plan, index, sub, bytes, writer, wall_now());
  const DriftChange change = apply_check(m.st.drift, check);
  if (change == DriftChange::none) return;
  dirty = true;
  if (change == DriftChange::restored) {
    const std::string text = check.record.object + " set back to its configured value " +
                             number_text(check.record.configured) + " by " + writer;
    log->info("bus {}: device {}: {}", bus.name, m.st.name, text);
    add_event(m, TimelineKind::drift, text);
    follow_written_heartbeat(m, check.record);
    return;
  }
  const std::string text = drift_text(check.record);
  const bool restore = m.cfg.on_config_drift == config::DriftPolicy::restore;
  log->warn("bus {}: device {}: configuration differs: {}; {}", bus.name, m.st.name, text,
            restore ? "restoring the configuration (on_config_drift = \"restore\")"
                    : "kept until the next configuration (on_config_drift = \"keep\")");
  add_event(m, TimelineKind::drift, text);
  notify(m);
  if (restore) {
    restore_configuration(m, now);
  } else {
    follow_written_heartbeat(m, check.record);
  }
}

void BusManager::Impl::note_command_writes(Managed& m, const ConfigPlan& command_plan, const DeviceCommand& cmd,
                                           TimePoint now) {
  for (const auto& step : command_plan.steps) {
    if (step.kind != StepKind::write) continue;
    std::array<std::uint8_t, 4> bytes{};
    for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(step.write.value >> (8U * i));
    note_client_write(m, step.write.index, step.write.sub, std::span(bytes.data(), step.write.size),
                      cmd.source.empty() ? std::string("a plugin") : cmd.source, now);
  }
}

// The full plan, as after a boot-up: it rewrites what differs, verifies and
// stores; mark_operational() clears the drift when it succeeds.
// A device a client stopped (operator_hold) is not started by a restore:
// the restore waits for the client's NMT start (on_nmt_sent).
void BusManager::Impl::restore_configuration(Managed& m, TimePoint now) {
  if (m.runner || m.description == nullptr || !m.profile) return;  // a plan is on its way anyway
  if (m.operator_hold) return;
  m.force_full = true;
  m.want_configure = true;
  m.attempts = 0;
  m.not_before = now;
  // The plan passes through pre-operational: not a foreign NMT master's doing.
  m.started = false;
  supervisor.listen(m.st.node_id, m.profile->family);
}

// Keep: the heartbeat consumer follows the producer time the device now
// has (CiA 301 §7.4.8.3), rather than declaring it lost for obeying a
// client; a write back to the configured time restores the configured watch.
void BusManager::Impl::follow_written_heartbeat(Managed& m, const DriftRecord& r) {
  if (r.index != 0x1017 || r.sub != 0) return;
  if (m.supervision.mode != Supervision::Mode::heartbeat) return;
  const milliseconds producer(r.value);
  if (!supervisor.follow_producer_time(m.st.node_id, producer)) return;
  if (producer.count() == 0) {
    log->warn("bus {}: device {}: heartbeat switched off by a client: no longer supervised until reconfigured",
              bus.name, m.st.name);
  } else {
    log->info("bus {}: device {}: heartbeat consumer follows the producer time of {} ms", bus.name, m.st.name,
              producer.count());
  }
}

// A plan that succeeded wrote every configured value: no drift is left.
void BusManager::Impl::clear_drift(Managed& m) {
  if (m.st.drift.empty()) return;
  std::string objects;
  for (const auto& r : m.st.drift) objects += (objects.empty() ? "" : ", ") + r.object;
  m.st.drift.clear();
  log->info("bus {}: device {}: configuration restored ({})", bus.name, m.st.name, objects);
  add_event(m, TimelineKind::drift, "restored the configuration of " + objects);
}

}  // namespace cobridge::gateway
