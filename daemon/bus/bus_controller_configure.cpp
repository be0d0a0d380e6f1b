// BusController: configuration plans (full and quick), NMT start, and
// the plugins' commands run as plans. Control thread only.
#include "bus/bus_controller.hpp"

#include <algorithm>

namespace cobridge::bus {

bool BusController::start_configurations(TimePoint now) {
  if (discovery->commissioning()) return false;  // LSS/NMT resets under way: no SDO now
  // Attempts made on a closed interface would only count towards `failed`.
  if (!channel->is_open()) return false;
  std::size_t active = 0;
  for (const auto& m : devices) active += m.runner ? 1U : 0U;
  bool started_any = false;
  for (auto& m : devices) {
    if (active >= kMaxConcurrentPlans) break;
    if (!m.configuration_due(now)) continue;
    if (m.st.node_id == services->sdo_node()) continue;  // a client's transfer runs on it: next turn
    m.want_configure = false;
    if (begin_configuration(m, now)) {
      ++active;
      started_any = true;
    }
  }
  return started_any;
}

PlanRunnerOptions BusController::runner_options() const {
  PlanRunnerOptions ro;
  ro.sdo_retries = bus.sdo_retries;
  return ro;
}

std::unique_ptr<PlanRunner> BusController::make_runner(DeviceAgent& m, ConfigPlan plan, const PlanRunnerOptions& ro) {
  return std::make_unique<PlanRunner>(tx, sdo_of(m), std::move(plan), ro);
}

canopen::SdoClient& BusController::sdo_of(DeviceAgent& m) {
  if (!m.sdo) {
    canopen::SdoClientConfig sc;
    sc.timeout = milliseconds(bus.sdo_timeout_ms);
    sc.retries = 0;  // the runner repeats timed-out transfers itself
    m.sdo = std::make_unique<canopen::SdoClient>(tx, m.st.node_id, sc);
  } else if (!m.sdo->busy()) {
    (void)m.sdo->set_node_id(m.st.node_id);
  }
  return *m.sdo;
}

bool BusController::begin_configuration(DeviceAgent& m, TimePoint now) {
  // A client's value may be stored in the device: only the full plan sees
  // every configured object again (a contested one is left alone).
  if (std::any_of(m.st.drift.begin(), m.st.drift.end(), [](const DriftRecord& r) { return !r.contested; }))
    m.force_full = true;
  if (m.started && m.force_full) {
    // A restore after its backoff: the device was watched until now, and
    // the plan passes through pre-operational (not a foreign master's doing).
    m.started = false;
    supervisor.listen(m.st.node_id, m.profile->family);
  }
  if (!m.plan || m.plan->node_id != m.st.node_id || m.force_full) {
    auto result = make_config_plan(m.cfg, *m.description, *m.profile, m.st.node_id);
    if (!result.ok()) {
      std::string text;
      for (const auto& err : result.errors) {
        if (!text.empty()) text += "; ";
        text += err.to_string();
      }
      m.st.last_error = text;
      log->error("bus {}: {}", bus.name, text);
      add_problem(text, m.st.name);
      set_state(m, DeviceState::failed);
      return false;
    }
    m.plan = std::move(result.plan);
  }
  m.supervision = m.supervision_wanted();
  PlanRunnerOptions ro = runner_options();

  // A device that carries the fingerprint of this plan (state file) only
  // gets a quick read-back of its key objects; the full plan runs when they
  // disagree (it lost or changed its configuration) or when the family
  // keeps part of the settings in volatile memory only.
  const auto previous = state.find(bus.name, m.st.identity.vendor, m.st.identity.product, m.st.identity.serial);
  const bool volatile_parts = !m.profile->cams_stored && !m.cfg.cams.empty();
  m.quick = !m.force_full && previous && previous->fingerprint == m.plan->fingerprint && !volatile_parts;
  ConfigPlan run_plan = m.plan_to_run();
  // The start is ours (finish_configuration): the hot path learns the
  // mapping first, so the first TPDO after the start is decoded.
  ro.start_node = false;
  m.begin_attempt(now);
  m.runner = make_runner(m, std::move(run_plan), ro);
  set_state(m, DeviceState::configuring);
  if (const Error e = m.runner->start(now)) {
    log->error("bus {}: device {}: plan not started: {}", bus.name, m.st.name, e.message);
    m.runner.reset();
    m.retry_soon(now);
    return false;
  }
  return true;
}

void BusController::finish_configuration(DeviceAgent& m, TimePoint now) {
  const PlanRunResult outcome = m.runner->result();
  m.runner.reset();
  const double ms = std::chrono::duration<double, std::milli>(now - m.configure_started).count();
  StepTiming t;
  t.step = (m.quick ? "verify " : "configure ") + m.st.name;
  t.device = m.st.name;
  t.milliseconds = ms;
  add_step(std::move(t));
  switch (m.judge_run(outcome, now)) {
    case RunVerdict::failed:
      return configuration_failed(m, outcome, now);
    case RunVerdict::configuration_lost:
      add_event(m, TimelineKind::mismatch,
                "the device no longer carries its stored configuration: " + join_differences(outcome) +
                    "; the full plan runs");
      log->info("bus {}: device {}: key objects differed from the stored configuration; full plan", bus.name,
                m.st.name);
      return;
    case RunVerdict::configured:
      break;
  }
  remember_assignment(m, m.plan->fingerprint);
  if (!announce_and_start(m, now)) return;
  mark_operational(m, outcome, now, ms);
  restore_left_drift(m, now);
}

// Retries after a short delay, or after a long one once the attempts are
// used up.
void BusController::configuration_failed(DeviceAgent& m, const PlanRunResult& outcome, TimePoint now) {
  m.st.last_error = outcome.error.message;
  note_failure(m, outcome);
  log->warn("bus {}: device {}: configuration failed (attempt {}): {}", bus.name, m.st.name, m.attempts,
            outcome.error.message);
  set_state(m, m.note_failed_attempt(now) ? DeviceState::failed : DeviceState::identified);
}

// The timeline's entry for a failed plan: an SDO abort (CiA 301 text) or
// timeout, or a value that read back different; the frames are captured.
void BusController::note_failure(DeviceAgent& m, const PlanRunResult& outcome) {
  const auto& code = outcome.error.code;
  TimelineKind kind = TimelineKind::sdo;
  const char* cause = nullptr;  // the flight recorder's (CiA 301 §7.2.4.3.17: aborted, or never answered)
  if (code == make_error_code(PlanRunErrc::verify_mismatch)) {
    kind = TimelineKind::mismatch;
    cause = "configuration mismatch";
  } else if (code == make_error_code(PlanRunErrc::sdo_timeout)) {
    cause = "sdo timeout";
  } else if (code == make_error_code(PlanRunErrc::sdo_abort)) {
    cause = "sdo abort";
  } else if (code != make_error_code(PlanRunErrc::send_failed)) {
    return;  // the client was busy: nothing happened on the bus
  }
  add_event(m, kind, "configuration attempt " + std::to_string(m.attempts) + " failed: " + outcome.error.message,
            cause != nullptr ? capture(cause, m.st.name) : std::string());
}

std::string BusController::join_differences(const PlanRunResult& outcome) {
  std::string text;
  for (const auto& d : outcome.differed) text += (text.empty() ? "" : "; ") + d;
  if (outcome.writes > outcome.differed.size()) text += " (and more)";
  return text.empty() ? "a PDO mapping differs" : text;
}

// Stores the device's node-ID and plan fingerprint, so that its next start
// only verifies.
void BusController::remember_assignment(const DeviceAgent& m, const std::string& fingerprint) {
  Assignment a;
  a.bus = bus.name;
  a.serial = m.st.identity.serial;
  a.vendor = m.st.identity.vendor;
  a.product = m.st.identity.product;
  a.revision = m.st.identity.revision;
  a.node_id = m.st.node_id;
  a.fingerprint = fingerprint;
  if (const Error err = state.put(a)) log->error("bus {}: state file {}", bus.name, err.to_string());
}

void BusController::note_configured(DeviceAgent& m, const PlanRunResult& outcome) {
  std::string text = m.quick ? "configuration checked: the device carries it" : "configured: ";
  if (!m.quick) {
    text += std::to_string(outcome.writes) + " value(s) written and verified";
    if (outcome.stored) text += ", stored";
    if (outcome.writes > 0) text += " (" + join_differences(outcome) + ")";
  }
  if (outcome.guarding_fallback) text += "; heartbeat refused, node guarding instead";
  add_event(m, TimelineKind::configured, std::move(text));
}

// Started: operational from here, and supervised from now on.
void BusController::mark_operational(DeviceAgent& m, const PlanRunResult& outcome, TimePoint now, double ms) {
  m.started = true;
  m.attempts = 0;
  m.st.last_error.clear();
  m.st.nmt = canopen::NmtState::operational;
  supervisor.watch(m.st.node_id, m.profile->family, m.supervision, now);
  m.st.online = m.supervision.mode == Supervision::Mode::none;
  note_configured(m, outcome);
  clear_drift(m);
  set_state(m, DeviceState::operational);
  if (board.clear_device(m.st.name)) dirty = true;
  if (m.boot_up_at != kNever) {
    const double back = std::chrono::duration<double, std::milli>(now - m.boot_up_at).count();
    log->info("bus {}: device {} back in operation {:.0f} ms after its boot-up ({} writes, {} saves)", bus.name,
              m.st.name, back, outcome.writes, outcome.saves);
    StepTiming bt;
    bt.step = "back after boot-up";
    bt.device = m.st.name;
    bt.milliseconds = back;
    add_step(std::move(bt));
    m.boot_up_at = kNever;
  } else {
    log->info("bus {}: device {} operational at node {} ({:.0f} ms, {} writes, {} saves)", bus.name, m.st.name,
              m.st.node_id, ms, outcome.writes, outcome.saves);
  }
}

bool BusController::announce_and_start(DeviceAgent& m, TimePoint now) {
  if (options.observer != nullptr) {
    std::vector<std::uint32_t> tpdo1, tpdo2;
    for (const auto& step : m.plan->steps) {
      if (step.kind != StepKind::tpdo_mapping) continue;
      if (step.tpdo == 1) tpdo1 = step.mapping;
      if (step.tpdo == 2) tpdo2 = step.mapping;
    }
    DeviceStatus announced = m.st;
    announced.state = DeviceState::operational;
    announced.nmt = canopen::NmtState::operational;
    options.observer->on_device_configured(announced, tpdo1, tpdo2);
  }
  if (channel->send(canopen::make_nmt(canopen::NmtCommand::start, m.st.node_id))) {
    m.note_start_sent(std::chrono::duration_cast<std::chrono::nanoseconds>(wall_now().time_since_epoch()).count(),
                      now);
    return true;
  }
  m.st.last_error = "NMT start could not be sent";
  m.retry_soon(now);
  return false;
}

void BusController::runners_abort() {
  for (auto& m : devices) drop_runner(m, "the gateway is stopping");
}

void BusController::drop_runner(DeviceAgent& m, const char* why) {
  if (m.command && m.runner && m.runner->finished()) {
    // Done before what ends it was seen (an NMT reset's own boot-up can
    // arrive in the same loop turn): the command's outcome stands.
    finish_command(m, steady_now());
    return;
  }
  m.runner.reset();
  if (!m.command) return;
  DeviceCommand cmd = std::move(*m.command);
  m.command.reset();
  report_command(m, cmd, CommandOutcome{CommandStatus::failed, 0, std::string("aborted: ") + why});
}

void BusController::report_command(const DeviceAgent& m, const DeviceCommand& cmd, const CommandOutcome& outcome) {
  if (outcome.status == CommandStatus::ok) {
    log->info("bus {}: device {}: {} done", bus.name, m.st.name, to_string(cmd.kind));
  } else {
    log->warn("bus {}: device {}: {}: {}{}{}", bus.name, m.st.name, to_string(cmd.kind), to_string(outcome.status),
              outcome.message.empty() ? "" : ": ", outcome.message);
  }
  if (options.observer != nullptr) options.observer->on_command_done(m.st, cmd, outcome);
}

void BusController::start_command(DeviceCommand cmd, TimePoint now) {
  DeviceAgent* m = find_device(cmd.device);
  if (m == nullptr || !m->in_config) {
    DeviceAgent none;
    none.st.name = cmd.device;
    none.st.bus = bus.name;
    report_command(none, cmd, CommandOutcome{CommandStatus::unknown_device, 0, "not configured on this bus"});
    return;
  }
  if (standby()) {
    report_command(*m, cmd,
                   CommandOutcome{CommandStatus::busy, 0,
                                  "this gateway is standby; the master (node " +
                                      std::to_string(election->master_node()) + ") runs commands"});
    return;
  }
  if (m->runner || m->st.node_id == services->sdo_node()) {
    report_command(*m, cmd,
                   CommandOutcome{CommandStatus::busy, 0, m->command ? "another command runs" : "being configured"});
    return;
  }
  if (m->st.state != DeviceState::operational || m->description == nullptr || !m->profile || m->st.node_id == 0) {
    report_command(*m, cmd,
                   CommandOutcome{CommandStatus::offline, 0, std::string("device is ") + to_string(m->st.state)});
    return;
  }
  auto plan = make_command_plan(m->st.name, *m->description, *m->profile, m->st.node_id, cmd.kind, cmd.value);
  if (!plan.ok()) {
    std::string text;
    bool range = false;
    for (const auto& err : plan.errors) {
      if (!text.empty()) text += "; ";
      text += err.to_string();
      range = range || err.out_of_range;
    }
    report_command(*m, cmd,
                   CommandOutcome{range ? CommandStatus::invalid_value : CommandStatus::unsupported, 0, text});
    return;
  }
  log->info("bus {}: device {}: {}{} requested by an output", bus.name, m->st.name, to_string(cmd.kind),
            cmd.kind == CommandKind::preset ? " to " + std::to_string(cmd.value) : std::string());
  m->command = std::move(cmd);
  m->runner = make_runner(*m, std::move(*plan.plan), runner_options());
  if (const Error e = m->runner->start(now)) drop_runner(*m, e.message.c_str());
}

void BusController::finish_command(DeviceAgent& m, TimePoint now) {
  const PlanRunResult r = m.runner->result();
  const ConfigPlan command_plan = m.runner->plan();
  m.runner.reset();
  DeviceCommand cmd = std::move(*m.command);
  m.command.reset();
  // A preset of an object the configuration presets (`preset`) is drift.
  if (r.ok()) note_command_writes(m, command_plan, cmd, now);
  if (cmd.kind == CommandKind::store) m.expect_pre_operational(now);
  CommandOutcome out;
  out.message = r.error.message;
  if (r.ok()) {
    out.status = CommandStatus::ok;
  } else if (r.error.code == make_error_code(PlanRunErrc::sdo_abort)) {
    out.status = CommandStatus::refused;
    out.abort_code = static_cast<std::uint32_t>(r.sdo_error.value());
  } else if (r.error.code == make_error_code(PlanRunErrc::sdo_timeout)) {
    out.status = CommandStatus::timeout;
  } else if (r.error.code == make_error_code(PlanRunErrc::sdo_busy)) {
    out.status = CommandStatus::busy;
  } else {
    out.status = CommandStatus::failed;
  }
  report_command(m, cmd, out);
}

}  // namespace cobridge::bus
