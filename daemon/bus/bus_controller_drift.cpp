// BusController: configuration drift. A client's confirmed write (CLI /
// control socket, CiA 309-3, a plugin's preset, or another SDO client on the
// bus, canopen/sdo_observer.hpp) of an object the device's plan sets, to
// another value, is recorded on the device (status "configuration differs"),
// put on its timeline and logged once; then, per the device's
// on_config_drift, the full plan runs again (restore) or the operator's value
// stays until the next plan runs (keep). Restores go through the device's
// RestoreGuard (bus/restore_guard.hpp): a writer that keeps changing an
// object meets three restores, then the object is contested and left alone
// until an operator acknowledges it. Control thread only.
#include "bus/bus_controller.hpp"
#include "bus/config_drift.hpp"

#include <algorithm>
#include <array>
#include <span>

namespace cobridge::bus {

void BusController::on_sdo_written(const ServiceRequest& c, TimePoint now) {
  for (auto& m : devices) {
    if (m.in_config && m.st.node_id == c.node) note_client_write(m, c.index, c.sub, c.data, c.caller, now);
  }
}

void BusController::on_foreign_write(const canopen::ObservedWrite& w, TimePoint now) {
  DeviceAgent* m = find_node(w.node);
  if (m == nullptr) return;
  note_client_write(*m, w.index, w.sub, std::span(w.data.data(), w.size),
                    "an SDO client on the bus (not through the gateway)", now);
}

void BusController::note_client_write(DeviceAgent& m, std::uint16_t index, std::uint8_t sub,
                                         std::span<const std::uint8_t> bytes, const std::string& writer,
                                         TimePoint now) {
  note_drift(m, index, sub, bytes, writer, now);
  // After the consumer followed a written time (note_drift), as it now is.
  if (index == 0x1017 && sub == 0) supervisor.producer_time_written(m.st.node_id, now);
}

void BusController::note_drift(DeviceAgent& m, std::uint16_t index, std::uint8_t sub,
                                  std::span<const std::uint8_t> bytes, const std::string& writer, TimePoint now) {
  if (!m.plan || standby()) return;
  const DriftCheck check = check_write(*m.plan, index, sub, bytes, writer, wall_now());
  if (!check.configured || repeats_open_record(m.st.drift, check)) return;  // nothing new: no line per repeat
  if (DriftRecord* open = open_record(m.st.drift, index, sub); open != nullptr && open->contested) {
    note_contested_write(m, *open, check.record);
    return;
  }
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
    request_restore(m, index, sub, now);
  } else {
    follow_written_heartbeat(m, check.record);
  }
}

void BusController::note_command_writes(DeviceAgent& m, const ConfigPlan& command_plan, const DeviceCommand& cmd,
                                           TimePoint now) {
  for (const auto& step : command_plan.steps) {
    if (step.kind != StepKind::write) continue;
    std::array<std::uint8_t, 4> bytes{};
    for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(step.write.value >> (8U * i));
    note_client_write(m, step.write.index, step.write.sub, std::span(bytes.data(), step.write.size),
                      cmd.source.empty() ? std::string("a plugin") : cmd.source, now);
  }
}

void BusController::request_restore(DeviceAgent& m, std::uint16_t index, std::uint8_t sub, TimePoint now) {
  DriftRecord* r = open_record(m.st.drift, index, sub);
  if (r == nullptr) return;
  const RestoreDecision d = m.judge_restore(*r, now);
  switch (d.verdict) {
    case RestoreVerdict::after_the_plan:
    case RestoreVerdict::on_its_way:
      return;
    case RestoreVerdict::restore:
      // While the restore waits out its backoff the device runs with the
      // client's value: supervised as it now is, not declared lost for it.
      if (d.not_before > now) follow_written_heartbeat(m, *r);
      restore_configuration(m, now, d.not_before);
      return;
    case RestoreVerdict::contested_now:
      mark_contested(m, *r);
      break;
    case RestoreVerdict::held:
      break;
  }
  // The device runs with the client's value now: supervise what it does.
  follow_written_heartbeat(m, *r);
}

// A contested object stays so until an operator acknowledges, whatever is
// written to it meanwhile (even the configured value: the other writer may
// change it again at once).
void BusController::note_contested_write(DeviceAgent& m, DriftRecord& open, const DriftRecord& now_written) {
  open.value = now_written.value;
  open.writer = now_written.writer;
  open.at = now_written.at;
  const std::string text = "contested " + open.object + " written to " + number_text(open.value) + " by " +
                           open.writer + "; left as it is until acknowledged";
  log->info("bus {}: device {}: {}", bus.name, m.st.name, text);
  add_event(m, TimelineKind::drift, text);
  dirty = true;
  follow_written_heartbeat(m, open);
}

void BusController::mark_contested(DeviceAgent& m, const DriftRecord& r) {
  const std::string text = r.object + (r.name.empty() ? "" : " (" + r.name + ")") + " contested: " + r.writer +
                           " set it to " + number_text(r.value) + " again after " +
                           std::to_string(RestoreLimits::kMaxRestores) +
                           " restores within 10 minutes; the gateway writes and stores it no more until an "
                           "operator acknowledges (cobridge acknowledge " + m.st.name + ")";
  log->warn("bus {}: device {}: {}", bus.name, m.st.name, text);
  add_event(m, TimelineKind::drift, text);
  dirty = true;
  notify(m);
}

// The full plan, as after a boot-up: it rewrites what differs, verifies and
// stores what changed; mark_operational() clears the drift when it succeeds.
// A device a client stopped (operator_hold) is not started by a restore:
// the restore waits for the client's NMT start (on_nmt_sent). A command
// running on the device finishes first (start_configurations waits for it).
void BusController::restore_configuration(DeviceAgent& m, TimePoint now, TimePoint when) {
  if (!m.want_restore(when)) return;
  if (when > now) return;  // begin_configuration stops the watch when the plan starts
  // The plan passes through pre-operational: not a foreign NMT master's doing.
  m.started = false;
  supervisor.listen(m.st.node_id, m.profile->family);
}

// Keep: the heartbeat consumer follows the producer time the device now
// has (CiA 301 §7.4.8.3), rather than declaring it lost for obeying a
// client; a write back to the configured time restores the configured watch.
void BusController::follow_written_heartbeat(DeviceAgent& m, const DriftRecord& r) {
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

void BusController::clear_drift(DeviceAgent& m) {
  const std::string objects = m.close_restored_drift();
  if (objects.empty()) return;
  log->info("bus {}: device {}: configuration restored ({})", bus.name, m.st.name, objects);
  add_event(m, TimelineKind::drift, "restored the configuration of " + objects);
}

void BusController::restore_left_drift(DeviceAgent& m, TimePoint now) {
  m.drift_mid_plan.clear();
  if (m.cfg.on_config_drift != config::DriftPolicy::restore) return;
  for (const auto& r : std::vector<DriftRecord>(m.st.drift)) {
    if (!r.contested) request_restore(m, r.index, r.sub, now);
  }
}

void BusController::acknowledge_contested(const std::string& device, const std::string& caller, TimePoint now) {
  DeviceAgent* m = find_device(device);
  const std::optional<std::string> freed = m != nullptr ? m->acknowledge_contested() : std::nullopt;
  if (!freed) return;
  const std::string& objects = *freed;
  const std::string text = "contested configuration acknowledged by " + caller + " (" + objects + ")" +
                           (m->cfg.on_config_drift == config::DriftPolicy::restore ? "; restoring it" : "");
  log->info("bus {}: device {}: {}", bus.name, m->st.name, text);
  add_event(*m, TimelineKind::drift, text);
  dirty = true;
  notify(*m);
  // The operator's restore: not counted against the next contest.
  if (m->cfg.on_config_drift == config::DriftPolicy::restore) restore_configuration(*m, now, now);
}

}  // namespace cobridge::bus
