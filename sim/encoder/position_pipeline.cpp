#include "encoder/position_pipeline.hpp"

#include "encoder/abort_code.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "families/novotechnik_multiturn.hpp"
#include "families/novotechnik_rotary.hpp"
#include "families/family_traits.hpp"

namespace cobridge::sim {
namespace {

namespace fam = cobridge::families;

// An error position as the position object's raw bits.
constexpr std::uint32_t as_bits(std::int32_t position) noexcept { return static_cast<std::uint32_t>(position); }

constexpr double kTenthDegreesPerTurn = 3600.0;  // 1 turn/s = 360 deg/s = 3600 x 0.1 deg/s
constexpr double kTimeEpsilon = 1e-9;

std::int64_t floor_mod(std::int64_t a, std::int64_t m) noexcept {
  if (m <= 0) return a;
  const std::int64_t r = a % m;
  return r < 0 ? r + m : r;
}

std::int64_t floor_div(std::int64_t a, std::int64_t m) noexcept {
  const std::int64_t q = a / m;
  return (a % m != 0 && ((a < 0) != (m < 0))) ? q - 1 : q;
}

std::int64_t to_count(double counts) noexcept {
  // Far beyond any physical range, but keeps the cast defined.
  constexpr double kLimit = 9.0e15;
  return static_cast<std::int64_t>(std::floor(std::clamp(counts, -kLimit, kLimit)));
}


std::uint32_t clamp_u32(std::uint64_t v) noexcept {
  return v > std::numeric_limits<std::uint32_t>::max() ? std::numeric_limits<std::uint32_t>::max()
                                                       : static_cast<std::uint32_t>(v);
}

std::uint32_t as_int32_bits(std::int64_t v) noexcept {
  const auto clamped = std::clamp<std::int64_t>(v, std::numeric_limits<std::int32_t>::min(),
                                                std::numeric_limits<std::int32_t>::max());
  return static_cast<std::uint32_t>(static_cast<std::int32_t>(clamped));
}

}  // namespace

Resolution physical_resolution(FamilyId family) noexcept {
  switch (family) {
    case FamilyId::novotechnik_rotary: return {0x4000, 1};
    case FamilyId::novotechnik_multiturn: return {0x10000, 44};
    case FamilyId::ifm_rm: return {4096, 4096};
  }
  return {0x4000, 1};
}

RangeStatusBits range_status_bits(RangeState state) noexcept {
  RangeStatusBits b;
  switch (state) {
    case RangeState::in_range: break;
    case RangeState::info_over: b.status_1002 = 1U << 10; break;
    case RangeState::info_under: b.status_1002 = 1U << 11; break;
    case RangeState::error_over:
      b.status_1002 = 1U << 12;
      b.alarms_6503 = 1U << 13;
      break;
    case RangeState::error_under:
      b.status_1002 = 1U << 13;
      b.alarms_6503 = 1U << 12;
      break;
    case RangeState::warning_over:
      b.status_1002 = 1U << 20;
      b.warnings_6505 = 1U << 13;
      break;
    case RangeState::warning_under:
      b.status_1002 = 1U << 21;
      b.warnings_6505 = 1U << 12;
      break;
  }
  return b;
}

PositionSettings PositionSettings::defaults(FamilyId family) noexcept {
  return defaults(family, physical_resolution(family));
}

PositionSettings PositionSettings::defaults(FamilyId family, Resolution physical) noexcept {
  PositionSettings s;
  s.family = family;
  s.physical = physical;
  s.units_per_rev = physical.steps_per_rev;
  s.total_range = clamp_u32(physical.total());
  s.warning_margin = physical.steps_per_rev;
  switch (family) {
    case FamilyId::novotechnik_rotary:
      s.scaling_bit_active_high = true;  // J§1.4.1: bit 2 = 1 scaling on
      break;
    case FamilyId::novotechnik_multiturn:
      s.scaling_bit_active_high = false;  // E§5.3 as printed: bit 2 = 0 scaling on
      s.position_filter = 0;              // E§4.3 0x2010/1
      s.speed_integration_ms = 1;         // E§4.2 0x6031/2, paired with 0x2010/2 = 3
      break;
    case FamilyId::ifm_rm:
      s.scaling_bit_active_high = true;  // F§7.5 SFC: 1 = enabled
      s.speed_enabled = false;           // F§7.4 0x3010/1: off in the factory setting
      s.speed_mode = 0;
      break;
  }
  return s;
}

PositionPipeline::PositionPipeline(PositionSettings settings) noexcept : settings_(settings) {}

void PositionPipeline::reset_history() noexcept {
  head_ = 0;
  count_ = 0;
  have_scaled_ = false;
  latched_ = RangeState::in_range;
  last_ = PositionSample{};
}

bool PositionPipeline::scaling_active() const noexcept {
  const bool bit = (settings_.operating_parameter & 0x4U) != 0;
  return settings_.scaling_bit_active_high ? bit : !bit;
}

unsigned PositionPipeline::filter_exponent() const noexcept {
  switch (settings_.family) {
    case FamilyId::novotechnik_rotary: return (settings_.operating_parameter >> 12) & 0x7U;  // J§1.4.1
    case FamilyId::novotechnik_multiturn: return std::min<unsigned>(settings_.position_filter, 7);  // E§5.1
    case FamilyId::ifm_rm: return 0;
  }
  return 0;
}

std::uint64_t PositionPipeline::output_units_per_rev() const noexcept {
  return scaling_active() && settings_.units_per_rev != 0 ? settings_.units_per_rev : settings_.physical.steps_per_rev;
}

std::uint64_t PositionPipeline::output_total() const noexcept {
  return scaling_active() && settings_.total_range != 0 ? settings_.total_range : settings_.physical.total();
}

const PositionPipeline::Point& PositionPipeline::back(std::size_t age) const noexcept {
  return history_[(head_ + kHistory - age) % kHistory];
}

double PositionPipeline::filtered_turns() const noexcept {
  const std::size_t n = std::min<std::size_t>(std::size_t{1} << filter_exponent(), count_);
  double sum = 0.0;
  for (std::size_t age = 0; age < n; ++age) sum += back(age).turns;
  return sum / static_cast<double>(n);
}

double PositionPipeline::speed_turns_per_s() const noexcept {
  if (count_ < 2) return 0.0;
  std::size_t age = 1;
  double window = 0.0;
  switch (settings_.family) {
    case FamilyId::novotechnik_rotary:
      // J§1.4.1: the 2^n moving average applies to speed too; the mean of n
      // one-cycle speeds telescopes to the difference over n cycles.
      age = std::size_t{1} << filter_exponent();
      break;
    case FamilyId::novotechnik_multiturn:
      window = settings_.speed_integration_ms / 1000.0;  // E§4.2 0x6031/2
      break;
    case FamilyId::ifm_rm: {
      static constexpr double kWindows[] = {0.005, 0.05, 0.5};  // F§7.4 0x3010/2
      window = kWindows[std::min<unsigned>(settings_.speed_mode, 2)];
      break;
    }
  }
  const std::size_t oldest = count_ - 1;
  if (window > 0.0) {
    // Smallest age whose point lies at least `window` before the newest.
    const double newest = back(0).seconds;
    std::size_t lo = 1;
    std::size_t hi = oldest;
    while (lo < hi) {
      const std::size_t mid = lo + (hi - lo) / 2;
      if (newest - back(mid).seconds >= window - kTimeEpsilon) {
        hi = mid;
      } else {
        lo = mid + 1;
      }
    }
    age = lo;
  }
  age = std::min(age, oldest);
  const Point& a = back(0);
  const Point& b = back(age);
  const double dt = a.seconds - b.seconds;
  return dt > 0.0 ? (a.turns - b.turns) / dt : 0.0;
}

std::int64_t PositionPipeline::scale(std::int64_t count) const noexcept {
  if (!scaling_active()) return count;
  const auto pspr = static_cast<std::int64_t>(settings_.physical.steps_per_rev);
  const auto upr = static_cast<std::int64_t>(settings_.units_per_rev);
  if (pspr <= 0) return count;
  // count x units / physical units, split to keep the product in 64 bits.
  const std::int64_t q = floor_div(count, pspr);
  const std::int64_t r = count - q * pspr;
  const auto frac = static_cast<std::int64_t>(static_cast<std::uint64_t>(r) * static_cast<std::uint64_t>(upr) /
                                              static_cast<std::uint64_t>(pspr));
  std::int64_t scaled = q * upr + frac;
  if (fam::traits(settings_.family).position_wraps) scaled = floor_mod(scaled, static_cast<std::int64_t>(output_total()));
  return scaled;
}

std::int64_t PositionPipeline::apply_offset(std::int64_t scaled) const noexcept {
  if (!fam::traits(settings_.family).position_wraps) return scaled + offset_;  // E 0x6004 INTEGER32: no wrap
  const auto total = static_cast<std::int64_t>(output_total());
  if (settings_.preset_mode == PresetMode::offset_added) return floor_mod(scaled, total) + offset_;
  return floor_mod(scaled + offset_, total);
}

RangeState PositionPipeline::classify(std::int64_t count) noexcept {
  if (latched_ != RangeState::in_range) return latched_;  // E§9.1: only 0x2100 clears it
  const auto total = static_cast<std::int64_t>(settings_.physical.total());
  const auto spr = static_cast<std::int64_t>(settings_.physical.steps_per_rev);
  const auto margin = static_cast<std::int64_t>(settings_.warning_margin);
  if (count > total - 1) {
    if (count - (total - 1) <= margin) return RangeState::warning_over;
    latched_ = RangeState::error_over;
    return latched_;
  }
  if (count < 0) {
    if (-count <= margin) return RangeState::warning_under;
    latched_ = RangeState::error_under;
    return latched_;
  }
  if (count >= total - spr) return RangeState::info_over;  // last revolution (E§10.1 bit 10)
  if (count < spr) return RangeState::info_under;          // first revolution (bit 11)
  return RangeState::in_range;
}

void PositionPipeline::push_history(double shaft_turns, double seconds) noexcept {
  if (count_ > 0 && seconds <= back(0).seconds) {
    history_[head_].turns = shaft_turns;  // same instant: replace, do not fake a speed
  } else {
    head_ = (head_ + 1) % kHistory;
    history_[head_] = {seconds, shaft_turns};
    count_ = std::min(count_ + 1, kHistory);
  }
}

void PositionPipeline::set_speed(PositionSample& out) const noexcept {
  const auto& s = settings_;
  const double turns_per_s = speed_turns_per_s() * (counting_ccw() ? -1.0 : 1.0);
  double speed = 0.0;
  switch (fam::traits(s.family).speed_unit) {
    case fam::SpeedUnit::digits_per_s:  // F§7.4 0x3011
      speed = s.speed_enabled ? turns_per_s * static_cast<double>(output_units_per_rev()) : 0.0;
      break;
    case fam::SpeedUnit::deci_degree_per_s:  // E§3.4; J gives no unit and E's is taken
      speed = turns_per_s * kTenthDegreesPerTurn;
      break;
  }
  const double rounded = std::round(speed);
  constexpr double kMax16 = std::numeric_limits<std::int16_t>::max();
  constexpr double kMax32 = std::numeric_limits<std::int32_t>::max();
  out.speed_saturated = std::fabs(rounded) > kMax16;
  out.speed = static_cast<std::int16_t>(std::clamp(rounded, -kMax16, kMax16));
  out.speed32 = static_cast<std::int32_t>(std::clamp(rounded, -kMax32, kMax32));
}

bool PositionPipeline::error_value(RangeState range, std::uint32_t& sentinel) const noexcept {
  const fam::FamilyTraits& traits = fam::traits(settings_.family);
  if (measurement_error_) {
    if (traits.error_position) sentinel = as_bits(*traits.error_position);  // J§1.8, E§9.1
    return true;
  }
  if (range == RangeState::warning_over || range == RangeState::error_over) {
    sentinel = as_bits(fam::kMultiturnOverflowPosition);  // E§9.1 0x5051/x/1
    return true;
  }
  if (range == RangeState::warning_under || range == RangeState::error_under) {
    sentinel = as_bits(fam::kMultiturnUnderflowPosition);  // E§9.1 0x5051/x/2
    return true;
  }
  return false;
}

PositionSample PositionPipeline::update(double shaft_turns, double seconds) noexcept {
  push_history(shaft_turns, seconds);
  const auto& s = settings_;
  const auto ptotal = static_cast<std::int64_t>(s.physical.total());
  std::int64_t count = to_count((filtered_turns() + s.mount_offset_turns) * s.physical.steps_per_rev);
  if (counting_ccw()) count = ptotal - 1 - count;  // J§1.4.1: mirror within the range
  const fam::FamilyTraits& traits = fam::traits(s.family);
  if (traits.position_wraps) count = floor_mod(count, ptotal);

  PositionSample out;
  out.range = traits.range_monitoring ? classify(count) : RangeState::in_range;
  last_count_ = count;
  set_speed(out);

  std::uint32_t sentinel = 0;
  if (error_value(out.range, sentinel)) {
    out.error_value = true;
    out.speed = 0;  // J§1.8, E§9: speed value set to 0
    out.speed32 = 0;
    out.speed_saturated = false;
    if (!traits.error_position) {
      // F documents no error value: the last position is held.
      out.position = last_.position;
      out.value = last_.value;
      out.raw = last_.raw;
    } else {
      out.position = sentinel;
      out.value = last_.value;
      out.raw = sentinel;
    }
    last_ = out;
    return out;
  }

  scaled_ = scale(count);
  have_scaled_ = true;
  out.raw = static_cast<std::uint32_t>(count);
  out.value = apply_offset(scaled_);
  out.position = encode(out.value);
  last_ = out;
  return out;
}

std::uint32_t PositionPipeline::encode(std::int64_t value) const noexcept {
  if (!fam::traits(settings_.family).limit_switch_flags) return as_int32_bits(value);
  // F§7.4 0x2104/0x2105: bits 29..0 carry the value, bit 30 = at/below min, bit 31 = at/above max.
  std::uint32_t bits = static_cast<std::uint32_t>(value) & 0x3FFFFFFFU;
  if (settings_.limit_min_enabled && value <= static_cast<std::int64_t>(settings_.limit_min)) bits |= 1U << 30;
  if (settings_.limit_max_enabled && value >= static_cast<std::int64_t>(settings_.limit_max)) bits |= 1U << 31;
  return bits;
}

std::uint32_t PositionPipeline::preset(std::int64_t p) noexcept {
  if (const auto abort = check_preset(*this, p); abort != abort_code::kOk) return abort;
  preset_ = p;
  if (settings_.preset_mode == PresetMode::offset_added) {
    offset_ = p;
  } else {
    offset_ = p - (have_scaled_ ? scaled_ : 0);  // CiA 406: the current position now reads P
  }
  if (have_scaled_ && !last_.error_value) {
    last_.value = apply_offset(scaled_);
    last_.position = encode(last_.value);
  }
  return abort_code::kOk;
}

void PositionPipeline::restore_offset(std::int64_t offset, std::int64_t preset) noexcept {
  offset_ = offset;
  preset_ = preset;
}

bool PositionPipeline::position_error_reset() noexcept {
  if (latched_ == RangeState::in_range) return false;
  const auto total = static_cast<std::int64_t>(settings_.physical.total());
  if (last_count_ < 0 || last_count_ > total - 1) return false;  // E§4.3 0x2100: precondition back in range
  latched_ = RangeState::in_range;
  return true;
}

// ---- validation helpers ----

std::uint32_t check_scaling_write_allowed(const PositionSettings& s, std::uint16_t operating_parameter) noexcept {
  const bool bit = (operating_parameter & 0x4U) != 0;
  const bool on = s.scaling_bit_active_high ? bit : !bit;
  return on ? abort_code::kOk : abort_code::kWrongState;
}

std::uint32_t check_units_per_rev(const PositionSettings& s, std::uint32_t value) noexcept {
  return value == 0 || value > s.physical.steps_per_rev ? abort_code::kValueExceeded : abort_code::kOk;
}

std::uint32_t check_total_range(const PositionSettings& s, std::uint32_t value) noexcept {
  return value == 0 || value > s.physical.total() ? abort_code::kValueExceeded : abort_code::kOk;
}

std::uint32_t coupled_total_range(const PositionSettings& s, std::uint32_t units_per_rev) noexcept {
  return clamp_u32(static_cast<std::uint64_t>(units_per_rev) * s.physical.revolutions);
}

std::uint32_t coupled_units_per_rev(const PositionSettings& s, std::uint32_t total_range) noexcept {
  const std::uint32_t revs = s.physical.revolutions == 0 ? 1 : s.physical.revolutions;
  return std::max<std::uint32_t>(total_range / revs, 1);
}

std::uint32_t check_preset(const PositionPipeline& p, std::int64_t value) noexcept {
  if (p.settings().preset_mode == PresetMode::offset_added) {
    const bool fits = value >= std::numeric_limits<std::int32_t>::min() && value <= std::numeric_limits<std::int32_t>::max();
    return fits ? abort_code::kOk : abort_code::kValueExceeded;
  }
  const auto total = static_cast<std::int64_t>(p.output_total());
  return value < 0 || value >= total ? abort_code::kValueExceeded : abort_code::kOk;
}

std::uint32_t check_position_filter(std::uint8_t n) noexcept {
  return n > 7 ? abort_code::kValueExceeded : abort_code::kOk;
}

std::uint32_t check_speed_filter(std::uint8_t f) noexcept {
  return f > 8 ? abort_code::kValueExceeded : abort_code::kOk;
}

namespace {
constexpr std::uint16_t kIntegrationForFilter[] = {0, 0, 1, 1, 2, 3, 6, 12, 25};  // E§5.2, indexed by 0x2010/2
}

std::uint32_t check_speed_integration_ms(std::uint16_t ms) noexcept {
  for (const auto v : kIntegrationForFilter) {
    if (v == ms) return abort_code::kOk;
  }
  return abort_code::kValueExceeded;
}

std::uint16_t integration_ms_for_speed_filter(std::uint8_t f) noexcept {
  return kIntegrationForFilter[std::min<std::uint8_t>(f, 8)];
}

std::uint8_t speed_filter_for_integration_ms(std::uint16_t ms) noexcept {
  // E§5.2 lists 0 -> 0/1 and 1 -> 2/3; pick 0 and 3 so the default pair 1/3 survives (E§5.2).
  switch (ms) {
    case 0: return 0;
    case 1: return 3;
    case 2: return 4;
    case 3: return 5;
    case 6: return 6;
    case 12: return 7;
    case 25: return 8;
    default: return 3;
  }
}

std::uint32_t check_ifm_speed_mode(std::uint8_t mode) noexcept {
  return mode > 2 ? abort_code::kValueExceeded : abort_code::kOk;
}

std::uint32_t check_ifm_resolution_per_rev(const PositionSettings& s, std::uint32_t au) noexcept {
  return au == 0 || au > s.physical.steps_per_rev ? abort_code::kValueExceeded : abort_code::kOk;
}

std::uint32_t ifm_total_resolution_for(const PositionSettings& s, std::uint32_t au) noexcept {
  if (s.physical.steps_per_rev == 0) return 0;
  return clamp_u32(s.physical.total() * au / s.physical.steps_per_rev);  // GA = PGA x AU / PAU
}

std::uint32_t check_ifm_total_resolution(const PositionSettings& s, std::uint32_t ga, std::uint32_t au,
                                         bool require_formula) noexcept {
  const std::uint64_t pga = s.physical.total();
  if (ga == 0 || ga > pga) return abort_code::kValueExceeded;
  if (require_formula && ga != ifm_total_resolution_for(s, au)) return abort_code::kValueExceeded;
  if (ga < pga && s.physical.steps_per_rev != 0 && ga % s.physical.steps_per_rev != 0) return abort_code::kValueExceeded;
  return abort_code::kOk;
}

std::uint32_t check_ifm_limit_switch(const PositionSettings& s, std::uint32_t value) noexcept {
  return value > s.physical.total() ? abort_code::kValueExceeded : abort_code::kOk;
}

}  // namespace cobridge::sim
