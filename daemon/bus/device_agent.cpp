#include "bus/device_agent.hpp"

#include <algorithm>
#include <utility>

namespace cobridge::bus {

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

}  // namespace cobridge::bus
