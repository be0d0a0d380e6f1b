// BusController: frames to the protocol components, their outputs, bus
// events, and supervision (heartbeat / guarding, NMT state, EMCY).
// Control thread only.
#include "bus/bus_controller.hpp"

#include "bus/capture_writer.hpp"

namespace cobridge::bus {

void BusController::on_frame(const can::Frame& frame, TimePoint now, TimePoint arrived) {
  if (election_frame(frame, arrived)) return;  // a gateway's, not a device's
  // Another SDO client's requests (this socket never gets its own) are only
  // followed, to see what it writes; the responses go on to our clients too.
  const std::optional<canopen::ObservedWrite> written = sdo_observer.on_frame(frame, now);
  if (written) on_foreign_write(*written, now);
  if (standby()) listen_as_standby(frame, now);
  if (frame.id > canopen::cob::kSdoRxBase && frame.id <= canopen::cob::kSdoRxBase + 127) return;
  // While a client's LSS command runs, its answers are not discovery's.
  if (frame.id != canopen::cob::kLssSlaveToMaster || !services->lss_session(now)) discovery->on_frame(frame, now);
  services->on_frame(frame, now);
  supervisor.on_frame(frame, now);
  for (auto& m : devices) {
    if (m.runner) m.runner->on_frame(frame, now);
    if (m.ident) m.ident->on_frame(frame, now);
  }
}

TimePoint BusController::run_components(TimePoint now) {
  TimePoint next = kNever;
  next = std::min(next, channel->process(now));
  open_flag.store(channel->is_open());
  next = std::min(next, watch_health(now));
  if (election) {
    // The role is not handed over in the middle of a device's configuration,
    // which starts at its boot-up: a rebooted device waiting for its plan
    // counts as being configured.
    const bool configuring = std::any_of(devices.begin(), devices.end(), [](const DeviceAgent& m) {
      return m.runner != nullptr || (m.want_configure && m.boot_up_at != kNever);
    });
    election->set_busy(configuring);
    update_election_exclusions();
    next = std::min(next, election->process(now, *channel));
    report_suppressed_roles(now);
    next = std::min(next, role_log.report_due());
    next = std::min(next, report_ignored_election_frames(now));
    if (standby()) return run_standby(now, next);
  }
  if (!services->lss_session(now)) next = std::min(next, discovery->process(now));
  next = std::min(next, services->process(now, *this));
  services_waiting.store(services->waiting(), std::memory_order_relaxed);
  next = std::min(next, supervisor.process(now, tx));
  next = std::min(next, sync.process(now, tx));
  for (auto& m : devices) {
    if (m.runner) next = std::min(next, m.runner->process(now));
    if (m.want_configure && !m.runner) next = std::min(next, std::max(m.not_before, now));
    next = std::min(next, m.emcy_log.report_due());
    if (m.ident) next = std::min(next, m.ident->process(now));
    next = std::min(next, m.identity_wait(now));
  }
  return next;
}

bool BusController::handle_outputs(TimePoint now) {
  bool more = false;
  for (auto& e : discovery->take_events()) {
    on_discovery_event(e, now);
    more = true;
  }
  for (auto& t : discovery->take_timings()) {
    if (t.exchanges != 0)
      log->info("bus {}: {}{}{}: {:.0f} ms, {} LSS exchanges, {} timeouts{}", bus.name, t.step,
                t.device.empty() ? "" : " ", t.device, t.milliseconds, t.exchanges, t.timeouts,
                t.restarts == 0 ? std::string{} : fmt::format(", begun again {}x after late answers", t.restarts));
    add_step(std::move(t));
  }
  for (const auto& c : supervisor.take_changes()) {
    on_supervisor_change(c, now);
    more = true;
  }
  for (auto& m : devices) {
    if (m.runner && m.runner->finished()) {
      if (m.command) {
        finish_command(m, now);
      } else {
        finish_configuration(m, now);
      }
      more = true;
    }
  }
  for (auto& m : devices) {
    if (m.ident && m.ident->finished()) {
      finish_identity(m, now);
      more = true;
    }
  }
  start_identity_reads(now);
  if (start_configurations(now)) more = true;
  report_suppressed_emcy(now);
  report_control_drops(now);
  return more;
}

bool BusController::handle_bus_events(TimePoint now) {
  bool lost = false;
  for (const auto& ev : channel->take_events()) {
    const std::string text(can::to_string(ev.kind));
    const can::ControllerState before = controller.state;
    const bool good_news = ev.kind == can::BusEventKind::InterfaceReopened ||
                           ev.kind == can::BusEventKind::ErrorActive || ev.kind == can::BusEventKind::Restarted;
    const std::string file =
        good_news ? std::string() : capture(ev.kind == can::BusEventKind::InterfaceDown ? "adapter lost" : "bus error", {});
    if (controller.apply(ev)) {
      add_bus_event(TimelineKind::controller,
                    "CAN controller " + std::string(can::to_string(before)) + " -> " +
                        std::string(can::to_string(controller.state)),
                    file);
      log->warn("bus {}: CAN controller {} -> {}{}", bus.name, can::to_string(before), can::to_string(controller.state),
                controller.counters_known ? fmt::format(" (tx errors {}, rx errors {})", controller.tx_errors,
                                                        controller.rx_errors)
                                          : std::string());
    }
    if (good_news) {
      log->info("bus {}: {}", bus.name, text);
    } else {
      log->warn("bus {}: {}", bus.name, text);
    }
    live_bus_event = text;
    dirty = true;
    if (ev.kind == can::BusEventKind::InterfaceDown || ev.kind == can::BusEventKind::InterfaceReopened)
      add_bus_event(TimelineKind::controller, text, file);
    if (ev.kind == can::BusEventKind::InterfaceDown) {
      // Its devices cannot be heard any more: offline now (status and the
      // outputs tell the truth at once), not one heartbeat consumer time later.
      supervisor.bus_lost(now, "the CAN interface went down");
      lost = true;
      for (auto& m : devices) {
        m.drop_identity();  // asked again when the interface is back
        if (m.runner && m.command) {
          drop_runner(m, "the CAN interface went down");
        } else if (m.runner) {
          // The transfers cannot finish; the plan runs again once the bus is back.
          m.runner.reset();
          m.want_configure = true;
          m.not_before = now;
        }
      }
    } else if (ev.kind == can::BusEventKind::InterfaceReopened) {
      on_interface_back(now);
    }
  }
  return lost;
}

void BusController::on_interface_back(TimePoint now) {
  ++reopens_seen;
  for (auto& m : devices) {
    if (!m.in_config || m.st.node_id == 0) continue;
    discovery->set_supervised(m.st.node_id, false);
    if (m.description == nullptr || m.runner || m.command) continue;
    m.replan(now);
    supervisor.listen(m.st.node_id, m.profile->family);
  }
  log->info("bus {}: interface back; checking every known device", bus.name);
  check_configured_nodes(now);
}

std::string BusController::capture(const char* cause, const std::string& device) {
  if (options.captures == nullptr) return {};
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(wall_now().time_since_epoch()).count();
  return options.captures->request(cause, device, ns);
}

void BusController::on_supervisor_change(const Supervisor::Change& c, TimePoint now) {
  DeviceAgent* m = find_node(c.node);
  if (m == nullptr && !bus.discovery && c.kind == Supervisor::ChangeKind::rebooted) m = find_configured_node(c.node);
  if (m == nullptr) return;
  const DeviceState before = m->st.state;
  apply(c, m->st, wall_now());
  note_supervision(*m, c, before);
  dirty = true;
  notify(*m);
  switch (c.kind) {
    case Supervisor::ChangeKind::rebooted:
      log->info("bus {}: device {} (node {}) rebooted", bus.name, m->st.name, c.node);
      // Discovery re-identifies it after every boot-up (same serial, or a
      // replacement part); its `identified` event restarts the plan.
      m->boot_up_at = now;
      m->started = false;
      m->operator_hold = false;  // a restarted device is started again, whoever stopped it before
      drop_runner(*m, "the device rebooted");
      m->ident.reset();
      // Should discovery's re-identification not come, configure it anyway
      // (same node-ID, the identity it had) after a while.
      m->want_configure = m->description != nullptr;
      m->attempts = 0;
      m->not_before = now + kRebootFallbackDelay;
      if (!bus.discovery) {
        // Nobody else re-identifies it: read its identity now.
        m->want_configure = false;
        m->want_identity(now, true);
      }
      if (m->st.state != DeviceState::expected) set_state(*m, DeviceState::identified);
      break;
    case Supervisor::ChangeKind::offline:
      log->warn("bus {}: device {} (node {}) offline: {}", bus.name, m->st.name, c.node, c.reason);
      // Let discovery's periodic probe look at it: if it rebooted without a
      // boot-up we saw (interface loss), it is re-identified and configured.
      discovery->set_supervised(c.node, false);
      break;
    case Supervisor::ChangeKind::online:
      log->info("bus {}: device {} (node {}) online", bus.name, m->st.name, c.node);
      discovery->set_supervised(c.node, true);
      on_sign_of_life(*m, now);
      break;
    case Supervisor::ChangeKind::nmt_state:
      on_nmt_state(*m, c.nmt, c.frame_ns, now);
      break;
    case Supervisor::ChangeKind::emcy:
      if (emcy_log_allowed(*m, now)) log->warn("bus {}: device {} (node {}): {}", bus.name, m->st.name, c.node, c.emcy_text);
      on_sign_of_life(*m, now);
      break;
  }
}

// The timeline's side of a supervision change: what happened, in words,
// with the capture that holds its frames, and the state change it made.
void BusController::note_supervision(DeviceAgent& m, const Supervisor::Change& c, DeviceState before) {
  switch (c.kind) {
    case Supervisor::ChangeKind::rebooted:
      add_event(m, TimelineKind::boot_up,
                "boot-up message from node " + std::to_string(c.node) + ": the device restarted (boot-up " +
                    std::to_string(m.st.boot_ups) + " since the gateway started)",
                capture("boot-up", m.st.name));
      break;
    case Supervisor::ChangeKind::offline:
      add_event(m, TimelineKind::heartbeat, c.reason, capture("heartbeat lost", m.st.name));
      break;
    case Supervisor::ChangeKind::online:
      // A gap measured: back after a loss (the first heartbeat after a start is no news).
      if (!c.reason.empty()) add_event(m, TimelineKind::heartbeat, c.reason);
      break;
    case Supervisor::ChangeKind::emcy:
      add_event(m, TimelineKind::emcy, c.emcy_text, capture("emcy", m.st.name));
      break;
    case Supervisor::ChangeKind::nmt_state:
      break;
  }
  if (m.st.state != before) {
    add_event(m, TimelineKind::state, std::string(to_string(before)) + " -> " + to_string(m.st.state) + ": " +
                                          (m.st.state == DeviceState::offline ? c.reason : "heard again"));
  }
}

void BusController::on_nmt_state(DeviceAgent& m, canopen::NmtState nmt, std::int64_t frame_ns, TimePoint now) {
  const NmtVerdict verdict = m.judge_nmt(nmt, frame_ns, now, bus.foreign_nmt == config::ForeignNmt::restart);
  switch (verdict) {
    case NmtVerdict::ignore:
      return;
    case NmtVerdict::stale:
      // Sent before the device took our NMT start, read after it: no news.
      // Forgotten, so that the same state heard later is news.
      supervisor.forget_nmt(m.st.node_id);
      return;
    case NmtVerdict::operator_hold:
      set_state(m, DeviceState::stopped);  // a client's NMT command: left as asked
      return;
    case NmtVerdict::operational_again:
      log->info("bus {}: device {} (node {}) is operational again", bus.name, m.st.name, m.st.node_id);
      m.st.last_error.clear();
      set_state(m, m.st.online ? DeviceState::operational : DeviceState::offline);
      return;
    case NmtVerdict::stopped_left:
    case NmtVerdict::stopped_restart:
      return on_stopped_by_another(m, verdict == NmtVerdict::stopped_restart);
    case NmtVerdict::pre_operational_left:
      log->warn("bus {}: device {} (node {}) is pre-operational (another NMT master, or a reset whose boot-up was "
                "missed); left so (foreign_nmt = respect)", bus.name, m.st.name, m.st.node_id);
      m.st.last_error = "pre-operational: not started by this gateway";
      set_state(m, DeviceState::stopped);
      return;
    case NmtVerdict::resend_start:
      return resend_start(m, now);
    case NmtVerdict::replan:
      // Someone (or a reset we missed) put it back: check, configure and start again.
      log->warn("bus {}: device {} (node {}) is pre-operational again; reconfiguring", bus.name, m.st.name,
                m.st.node_id);
      m.replan(now);
      supervisor.listen(m.st.node_id, m.profile ? m.profile->family : nullptr);
      set_state(m, DeviceState::identified);
      return;
  }
}

void BusController::on_stopped_by_another(DeviceAgent& m, bool restart) {
  m.st.last_error = "stopped by another NMT master";
  set_state(m, DeviceState::stopped);
  if (!restart) {
    log->warn("bus {}: device {} (node {}) was stopped by another NMT master; left stopped (foreign_nmt = "
              "respect)", bus.name, m.st.name, m.st.node_id);
    return;
  }
  log->warn("bus {}: device {} (node {}) was stopped by another NMT master; starting it again", bus.name,
            m.st.name, m.st.node_id);
  if (!channel->send(canopen::make_nmt(canopen::NmtCommand::start, m.st.node_id)))
    log->error("bus {}: device {}: NMT start could not be sent", bus.name, m.st.name);
}

// See kStartResends. Forgotten by the supervisor, so that the same state
// heard again is news: after the window, the whole plan.
void BusController::resend_start(DeviceAgent& m, TimePoint now) {
  supervisor.forget_nmt(m.st.node_id);
  log->warn("bus {}: device {} (node {}) still pre-operational {} ms after the NMT start; start sent again ({} of {})",
            bus.name, m.st.name, m.st.node_id,
            std::chrono::duration_cast<std::chrono::milliseconds>(m.since_start(now)).count(), m.start_resends(),
            kStartResends);
  if (!channel->send(canopen::make_nmt(canopen::NmtCommand::start, m.st.node_id)))
    log->error("bus {}: device {}: NMT start could not be sent", bus.name, m.st.name);
}

void BusController::report_suppressed_emcy(TimePoint now) {
  for (auto& m : devices) {
    if (const std::uint32_t n = m.emcy_log.take_suppressed(now))
      log->warn("bus {}: device {} (node {}): {} more EMCY not logged (last: {}); every one reached the outputs",
                bus.name, m.st.name, m.st.node_id, n, m.st.last_emcy_text);
  }
}

void BusController::report_control_drops(TimePoint now) {
  if (now < control_drops_report_at) return;
  const std::uint64_t total = channel->stats().rx_overflow_drops;
  if (total <= control_drops_reported) return;
  log->warn("bus {}: the kernel dropped {} frames at the control thread's full receive queue ({} since start): "
            "EMCY, heartbeats or SDO answers among them went unseen by supervision and the log; the outputs "
            "read their own socket",
            bus.name, total - control_drops_reported, total);
  control_drops_reported = total;
  control_drops_report_at = now + kControlDropReportPeriod;
}

}  // namespace cobridge::bus
