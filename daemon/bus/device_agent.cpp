#include "bus/device_agent.hpp"

#include <algorithm>
#include <utility>

namespace cobridge::bus {

ConfigPlan quick_plan(const ConfigPlan& full) {
  ConfigPlan q = full;
  q.steps.clear();
  for (const auto& step : full.steps) {
    const bool key_write = step.kind == StepKind::write &&
                           (step.write.index == 0x1017 || step.write.index == 0x100C || step.write.index == 0x100D);
    if (step.kind == StepKind::nmt || step.kind == StepKind::tpdo_mapping || key_write) q.steps.push_back(step);
  }
  return q;
}

Supervision guarding_fallback(const ConfigPlan& plan) {
  Supervision s;
  s.mode = Supervision::Mode::guarding;
  for (const auto& step : plan.steps) {
    for (const auto& w : step.fallback) {
      if (w.index == 0x100C) s.guard_time = std::chrono::milliseconds(w.value);
      if (w.index == 0x100D) s.life_time_factor = static_cast<std::uint8_t>(w.value);
    }
  }
  if (s.guard_time.count() == 0 || s.life_time_factor == 0) s.mode = Supervision::Mode::none;
  return s;
}

void DeviceAgent::want_configuration(canopen::TimePoint when) noexcept {
  want_configure = true;
  attempts = 0;
  not_before = when;
}

bool DeviceAgent::configuration_due(canopen::TimePoint now) const noexcept {
  return want_configure && !runner && !ident && now >= not_before;
}

void DeviceAgent::begin_attempt(canopen::TimePoint now) noexcept {
  force_full = false;
  configure_started = now;
  ++attempts;
}

void DeviceAgent::retry_soon(canopen::TimePoint now) noexcept {
  want_configure = true;
  not_before = now + kConfigureRetryDelay;
}

void DeviceAgent::redo_at_once(canopen::TimePoint now) noexcept {
  want_configure = true;
  not_before = now;
  if (attempts > 0) --attempts;
}

bool DeviceAgent::note_failed_attempt(canopen::TimePoint now) noexcept {
  want_configure = true;
  if (attempts < kConfigureAttempts) {
    not_before = now + kConfigureRetryDelay;
    return false;
  }
  not_before = now + kFailedRetryPeriod;
  attempts = 0;
  return true;
}

RunVerdict DeviceAgent::judge_run(const PlanRunResult& outcome, canopen::TimePoint now) {
  const std::error_code code = outcome.error.code;
  failed_unanswered = !outcome.ok() && (code == make_error_code(PlanRunErrc::sdo_timeout) ||
                                        code == make_error_code(PlanRunErrc::send_failed));
  if (!outcome.ok()) return RunVerdict::failed;
  if (quick && outcome.writes > 0) {
    // The fingerprint matched but the device did not carry the values.
    force_full = true;
    store_all = true;
    redo_at_once(now);
    return RunVerdict::configuration_lost;
  }
  if (outcome.writes > 0) ++st.configurations;
  if (outcome.guarding_fallback) supervision = guarding_fallback(*plan);
  st.fingerprint = plan->fingerprint;
  return RunVerdict::configured;
}

ConfigPlan DeviceAgent::plan_to_run() {
  ConfigPlan run_plan = quick ? quick_plan(*plan) : *plan;
  leave_contested(run_plan);
  if (store_all && plan->store_policy == config::StorePolicy::on_change) {
    // The quick check already put some values back, so "changed" would
    // miss them: store everything the plan names. A restore stores what
    // it changed only (the store wears the device's memory).
    run_plan.store_policy = config::StorePolicy::always;
  }
  store_all = false;
  return run_plan;
}

Supervision DeviceAgent::supervision_wanted() const {
  using std::chrono::milliseconds;
  Supervision s;
  if (cfg.guarding && cfg.guarding->guard_time_ms > 0 && cfg.guarding->life_time_factor > 0) {
    s.mode = Supervision::Mode::guarding;
    s.guard_time = milliseconds(cfg.guarding->guard_time_ms);
    s.life_time_factor = cfg.guarding->life_time_factor;
  } else if (plan && plan->heartbeat && plan->heartbeat_ms > 0) {
    s.mode = Supervision::Mode::heartbeat;
    s.producer_time = milliseconds(plan->heartbeat_ms);
  } else if (cfg.heartbeat_ms && *cfg.heartbeat_ms > 0) {
    s.mode = Supervision::Mode::heartbeat;
    s.producer_time = milliseconds(*cfg.heartbeat_ms);
  }
  return s;
}

void DeviceAgent::note_drift_mid_plan(std::uint16_t index, std::uint8_t sub) {
  const std::uint32_t key = object_number(index, sub);
  if (std::find(drift_mid_plan.begin(), drift_mid_plan.end(), key) == drift_mid_plan.end())
    drift_mid_plan.push_back(key);
}

namespace {

void append_object(std::string& list, const std::string& object) {
  list += (list.empty() ? "" : ", ") + object;
}

}  // namespace

std::string DeviceAgent::close_restored_drift() {
  std::vector<DriftRecord> left;
  std::string closed;
  for (auto& r : st.drift) {
    const std::uint32_t key = object_number(r.index, r.sub);
    const bool mid_plan = std::find(drift_mid_plan.begin(), drift_mid_plan.end(), key) != drift_mid_plan.end();
    if (r.contested || mid_plan) {
      left.push_back(std::move(r));
    } else {
      append_object(closed, r.object);
    }
  }
  st.drift = std::move(left);
  return closed;
}

void DeviceAgent::leave_contested(ConfigPlan& to_run) const {
  if (!restore_guard.any_contested()) return;
  std::erase_if(to_run.steps, [&](const PlanStep& step) {
    return step.kind == StepKind::write && restore_guard.contested(step.write.index, step.write.sub);
  });
}

RestoreDecision DeviceAgent::judge_restore(DriftRecord& r, canopen::TimePoint now) {
  if (runner && !command) {
    note_drift_mid_plan(r.index, r.sub);
    return {RestoreVerdict::after_the_plan, {}};
  }
  if (want_configure && force_full && !restore_guard.contested(r.index, r.sub)) return {RestoreVerdict::on_its_way, {}};
  const RestoreGuard::Decision d = restore_guard.on_drift(r.index, r.sub, now);
  r.restores = d.restores;
  if (d.verdict == RestoreGuard::Verdict::restore) return {RestoreVerdict::restore, d.not_before};
  r.contested = true;
  return {d.verdict == RestoreGuard::Verdict::contested ? RestoreVerdict::contested_now : RestoreVerdict::held, {}};
}

bool DeviceAgent::want_restore(canopen::TimePoint when) noexcept {
  if ((runner && !command) || description == nullptr || !profile || operator_hold) return false;
  force_full = true;
  want_configuration(when);
  return true;
}

std::optional<std::string> DeviceAgent::acknowledge_contested() {
  if (restore_guard.acknowledge() == 0) return std::nullopt;
  std::string freed;
  for (auto& r : st.drift) {
    if (!r.contested) continue;
    append_object(freed, r.object);
    r.contested = false;
    r.restores = 0;
  }
  return freed;
}

void DeviceAgent::note_start_sent(std::int64_t wall_ns, canopen::TimePoint now) noexcept {
  start_sent_ns_ = wall_ns;
  start_sent_at_ = now;
  start_resends_ = 0;
}

// By the frame's kernel stamp where it has one, within kStartStaleWindow
// of our start: sent before the start reached the device and was acted on
// (kStartReaction); a frame without a stamp within the settle after a
// command (kCommandSettle).
bool DeviceAgent::told_before_start(std::int64_t frame_ns, canopen::TimePoint now) const noexcept {
  if (now < preop_expected_until_) return true;
  if (frame_ns == 0 || start_sent_ns_ == 0 || now - start_sent_at_ > kStartStaleWindow) return false;
  return frame_ns < start_sent_ns_ + std::chrono::duration_cast<std::chrono::nanoseconds>(kStartReaction).count();
}

bool DeviceAgent::take_start_resend(canopen::TimePoint now) noexcept {
  if (start_sent_ns_ == 0 || now - start_sent_at_ > kStartStaleWindow || start_resends_ >= kStartResends)
    return false;
  ++start_resends_;
  return true;
}

NmtVerdict DeviceAgent::judge_nmt(canopen::NmtState nmt, std::int64_t frame_ns, canopen::TimePoint now,
                                  bool restart) noexcept {
  using canopen::NmtState;
  if (!started || runner) return NmtVerdict::ignore;
  if (nmt != NmtState::operational && told_before_start(frame_ns, now)) return NmtVerdict::stale;
  if (operator_hold && nmt != NmtState::operational) return NmtVerdict::operator_hold;
  switch (nmt) {
    case NmtState::operational:
      return st.state == DeviceState::stopped ? NmtVerdict::operational_again : NmtVerdict::ignore;
    case NmtState::stopped:
      if (st.state == DeviceState::stopped) return NmtVerdict::ignore;
      return restart ? NmtVerdict::stopped_restart : NmtVerdict::stopped_left;
    case NmtState::pre_operational:
      if (!restart) return NmtVerdict::pre_operational_left;
      return take_start_resend(now) ? NmtVerdict::resend_start : NmtVerdict::replan;
    case NmtState::boot_up:
      break;  // a boot-up is the supervisor's own change (Supervisor::ChangeKind::boot_up)
  }
  return NmtVerdict::ignore;
}

// ---- the identity check -------------------------------------------------------

void DeviceAgent::want_identity(canopen::TimePoint when, bool boot_up) noexcept {
  ident_wanted_ = true;
  ident_boot_up_ = ident_boot_up_ || boot_up;
  ident_at_ = when;
}

bool DeviceAgent::identity_due(canopen::TimePoint now) const noexcept {
  return ident_wanted_ && !ident && !runner && now >= ident_at_;
}

canopen::TimePoint DeviceAgent::identity_wait(canopen::TimePoint now) const noexcept {
  return ident_wanted_ && !ident ? std::max(ident_at_, now) : canopen::kNever;
}

void DeviceAgent::drop_identity() noexcept {
  ident.reset();
  ident_wanted_ = false;
}

IdentityVerdict DeviceAgent::judge_identity(const std::optional<canopen::LssAddress>& identity) const noexcept {
  if (!identity) return IdentityVerdict::unanswered;
  if (cfg.serial != 0 && identity->serial != cfg.serial) return IdentityVerdict::other_serial;
  return IdentityVerdict::identified;
}

// ---- the standby's view ---------------------------------------------------------

bool DeviceAgent::note_heard_state(bool operational) noexcept {
  const bool news = heard_operational != operational;
  heard_operational = operational;
  return news;
}

bool DeviceAgent::note_identity_heard(const canopen::LssAddress& id, std::uint8_t node) noexcept {
  if (!in_config || cfg.serial != id.serial || st.node_id == node) return false;
  if (cfg.vendor && *cfg.vendor != id.vendor) return false;
  st.node_id = node;
  st.identity = id;
  followed = false;
  return true;
}

DeviceStatus DeviceAgent::as_the_bus_says() const {
  DeviceStatus s = st;
  if (in_config && followed && heard_operational) {
    s.state = DeviceState::operational;
    s.nmt = canopen::NmtState::operational;
  }
  return s;
}

// ---- discovery's reports -------------------------------------------------------

IdentifiedVerdict DeviceAgent::judge_identified(const DiscoveryEvent& e, bool state_held) const noexcept {
  if (!e.at_target) {
    return e.target_node_id != 0 && state_held ? IdentifiedVerdict::held_in_place : IdentifiedVerdict::moving;
  }
  const bool same_device = st.identity.serial == e.identity.serial && st.identity.vendor == e.identity.vendor;
  const bool here = same_device && st.node_id == e.node_id;
  if (here && started && st.online && !e.boot_up && st.state == DeviceState::operational) {
    return IdentifiedVerdict::running_fine;
  }
  if (here && description != nullptr && (runner || want_configure)) return IdentifiedVerdict::on_its_way;
  return IdentifiedVerdict::reconfigure;
}

}  // namespace cobridge::bus
