#include "device/encoder_front_end.hpp"

#include <chrono>

#include "encoder/abort_code.hpp"
#include "families/family_traits.hpp"

namespace cobridge::sim {

namespace {

WorkAreaRule rule_for(FamilyId f) noexcept {
  switch (f) {
    case FamilyId::novotechnik_rotary: return WorkAreaRule::rotary;
    case FamilyId::novotechnik_multiturn: return WorkAreaRule::multiturn;
    case FamilyId::ifm_rm: return WorkAreaRule::ifm;
  }
  return WorkAreaRule::rotary;
}

}  // namespace

void EncoderFrontEnd::set_family(FamilyId family, Resolution physical) noexcept {
  family_ = family;
  physical_ = physical;
  for (Channel& c : channels_) {
    c.pipeline.emplace(PositionSettings::defaults(family, physical));
    c.cams = CamBank(families::family(family).models.front().cams_per_channel);  // J§1.2.3, E§3.4, F§7.5
    c.work_area.emplace(rule_for(family));
  }
}

Error EncoderFrontEnd::set_motion(std::string_view spec, TimePoint now) {
  if (started_ && spec == motion_.spec()) return {};
  MotionParseResult r = Motion::parse(spec);
  if (r.error) return std::move(r.error);
  const double offset = motion_.offset();
  motion_ = std::move(r.motion);
  motion_.set_offset(offset);
  if (!started_) {
    started_ = true;
    origin_ = now;
  }
  return {};
}

double EncoderFrontEnd::seconds(TimePoint now) const noexcept {
  return std::chrono::duration<double>(now - origin_).count();
}

void EncoderFrontEnd::configure(int channel, const ChannelConfig& c) noexcept {
  if (channel < 0 || channel >= kMaxChannels) return;
  Channel& ch = channels_[static_cast<std::size_t>(channel)];
  if (!ch.pipeline) set_family(family_, physical_);
  PositionSettings& s = ch.pipeline->settings();
  s.operating_parameter = c.operating_parameter;
  if (c.per_rev != 0) s.units_per_rev = c.per_rev;
  if (c.total != 0) s.total_range = c.total;
  s.position_filter = c.position_filter;
  s.speed_integration_ms = c.speed_integration_ms;
  s.speed_enabled = c.speed_enabled;
  s.speed_mode = c.speed_mode;
  s.limit_min_enabled = c.limit_min_enabled;
  s.limit_max_enabled = c.limit_max_enabled;
  s.limit_min = c.limit_min;
  s.limit_max = c.limit_max;
  ch.cams.set_enable_mask(c.cams.enable);
  ch.cams.set_polarity_mask(c.cams.polarity);
  for (std::size_t k = 0; k < ch.cams.size() && k < 8; ++k) {
    const CamLimits wanted{c.cams.low[k], c.cams.high[k], c.cams.hysteresis[k]};
    const CamLimits& have = ch.cams.limits(k);
    // Setting limits re-primes a CAM; only do it when they changed.
    if (have.low != wanted.low || have.high != wanted.high || have.hysteresis != wanted.hysteresis)
      ch.cams.set_limits(k, wanted);
  }
  if (ch.work_area) ch.work_area->limits() = c.work_area;
}

std::uint32_t EncoderFrontEnd::check_preset(int channel, std::int64_t value) const noexcept {
  if (channel < 0 || channel >= kMaxChannels) return abort_code::kSubIndexDoesNotExist;
  const Channel& ch = channels_[static_cast<std::size_t>(channel)];
  return ch.pipeline ? sim::check_preset(*ch.pipeline, value) : abort_code::kOk;
}

void EncoderFrontEnd::preset(int channel, std::int64_t value) noexcept {
  if (channel < 0 || channel >= kMaxChannels) return;
  Channel& ch = channels_[static_cast<std::size_t>(channel)];
  if (ch.pipeline) (void)ch.pipeline->preset(value);
}

std::int64_t EncoderFrontEnd::offset(int channel) const noexcept {
  if (channel < 0 || channel >= kMaxChannels) return 0;
  const Channel& ch = channels_[static_cast<std::size_t>(channel)];
  return ch.pipeline ? ch.pipeline->offset() : 0;
}

void EncoderFrontEnd::restore_offset(int channel, std::int64_t offset, std::int64_t preset_value) noexcept {
  if (channel < 0 || channel >= kMaxChannels) return;
  Channel& ch = channels_[static_cast<std::size_t>(channel)];
  if (ch.pipeline) ch.pipeline->restore_offset(offset, preset_value);
}

void EncoderFrontEnd::set_measurement_error(bool on) noexcept {
  for (Channel& ch : channels_)
    if (ch.pipeline) ch.pipeline->set_measurement_error(on);
}

bool EncoderFrontEnd::position_error_reset() noexcept {
  bool cleared = false;
  for (Channel& ch : channels_)
    if (ch.pipeline && ch.pipeline->position_error_reset()) cleared = true;
  return cleared;
}

void EncoderFrontEnd::reset() noexcept {
  for (Channel& ch : channels_) {
    if (ch.pipeline) ch.pipeline->reset_history();
    ch.cams.reset();
    if (ch.work_area) ch.work_area->reset();
  }
}

const PositionSettings* EncoderFrontEnd::settings(int channel) const noexcept {
  if (channel < 0 || channel >= kMaxChannels) return nullptr;
  const Channel& ch = channels_[static_cast<std::size_t>(channel)];
  return ch.pipeline ? &ch.pipeline->settings() : nullptr;
}

ChannelSample EncoderFrontEnd::measure(int channel, TimePoint now) noexcept {
  ChannelSample s;
  if (channel < 0 || channel >= kMaxChannels) return s;
  Channel& ch = channels_[static_cast<std::size_t>(channel)];
  if (!ch.pipeline) set_family(family_, physical_);
  const double t = seconds(now);
  s.shaft_turns = motion_.turns_at(t);
  const PositionSample p = ch.pipeline->update(s.shaft_turns, t);
  s.position_bits = p.position;
  s.position = p.value;
  s.raw = p.raw;
  s.speed = p.speed;
  s.speed32 = p.speed32;
  s.error_value = p.error_value;
  s.speed_saturated = p.speed_saturated;
  s.range = p.range;
  // J§1.8.1, E§9.1 0x5000: CAM and work-area states stay unchanged while the
  // position is an error value.
  if (!p.error_value) {
    const CamUpdate u = ch.cams.evaluate(p.value);
    s.cam_changed = u.changed;
    if (ch.work_area) (void)ch.work_area->evaluate(p.value);
  }
  s.cams = ch.cams.state();
  s.cam_active = ch.cams.active_mask();
  s.work_area = ch.work_area ? ch.work_area->state() : 0;
  return s;
}

}  // namespace cobridge::sim
