#include "encoder/condition_monitor.hpp"

#include "encoder/abort_code.hpp"

#include <cmath>

namespace cobridge::sim {
namespace {

constexpr double kSecondsPerTick = 360.0;  // 0.1 h (0x232A = 6 min, E§4.3)

std::uint32_t whole(double& fraction, double unit) noexcept {
  if (fraction < unit) return 0;
  const double n = std::floor(fraction / unit);
  fraction -= n * unit;
  return n > 4.0e9 ? 0xFFFFFFFFU : static_cast<std::uint32_t>(n);
}

}  // namespace

void MinMax::sample(std::int32_t v) noexcept {
  if (!has_min || v < min) min = v;
  if (!has_max || v > max) max = v;
  has_min = true;
  has_max = true;
}

void Tracker::sample(std::int32_t v) noexcept {
  power_on.sample(v);
  since_reset.sample(v);
  maintenance.sample(v);
  lifetime.sample(v);
}

void ConditionMonitor::power_up() noexcept {
  history_.temperature.power_on.clear();
  history_.voltage.power_on.clear();
  time_power_on_ = 0;
  lot_power_on_ = 0;
  odo_power_on_ = 0;
  ++history_.boot_since_maintenance;
  ++history_.boot_total;
  have_turns_ = false;
  have_cams_ = false;
  status_ = 0;  // RAM: threshold conditions are re-detected (and re-announced) after boot
}

void ConditionMonitor::restore(const ConditionHistory& h) noexcept {
  history_ = h;
  history_.temperature.power_on.clear();
  history_.voltage.power_on.clear();
}

void ConditionMonitor::threshold(ConditionEvents& ev, bool now, std::uint32_t bit, const ConditionEvent& event) noexcept {
  const bool was = (status_ & bit) != 0;
  if (now == was) return;
  status_ = now ? (status_ | bit) : (status_ & ~bit);
  if (event.code == 0) return;  // user thresholds: status bits only (E§4.3, E§5.8)
  ConditionEvent e = event;
  e.active = now;
  ev.push(e);
}

ConditionEvents ConditionMonitor::update(double dt_seconds, double shaft_turns, std::uint8_t cam_active) noexcept {
  ConditionEvents ev;
  history_.temperature.sample(temperature_);
  history_.voltage.sample(voltage_);

  // Operating time, 0.1 h ticks in all three windows at once.
  if (dt_seconds > 0.0) seconds_fraction_ += dt_seconds * time_scale;
  if (const std::uint32_t ticks = whole(seconds_fraction_, kSecondsPerTick); ticks != 0) {
    time_power_on_ += ticks;
    history_.time_since_maintenance += ticks;
    history_.time_total += ticks;
  }

  // Odometer: absolute movement in whole turns.
  if (have_turns_) turns_fraction_ += std::fabs(shaft_turns - last_turns_);
  last_turns_ = shaft_turns;
  have_turns_ = true;
  if (const std::uint32_t turns = whole(turns_fraction_, 1.0); turns != 0) {
    odo_power_on_ += turns;
    history_.odometer_since_maintenance += turns;
    history_.odometer_total += turns;
  }

  // Lot size: the CAM edge selected by 0x233A (E§4.3).
  if (have_cams_ && lot_size_config >= 1 && lot_size_config <= 4) {
    const unsigned bit = lot_size_config <= 2 ? 0U : 1U;
    const bool was = ((static_cast<unsigned>(last_cams_) >> bit) & 1U) != 0;
    const bool is = ((static_cast<unsigned>(cam_active) >> bit) & 1U) != 0;
    const bool rising = (lot_size_config % 2) == 1;
    if (rising ? (!was && is) : (was && !is)) {
      ++lot_power_on_;
      ++history_.lot_since_reset;
      ++history_.lot_since_maintenance;
      ++history_.lot_total;
    }
  }
  last_cams_ = cam_active;
  have_cams_ = true;

  // Thresholds (E§10.1 bits 2..9, E§9.1 0x4210 / 0x3100 warnings on the factory ones).
  const auto& t = thresholds;
  using Level = ConditionEvent::Level;
  threshold(ev, temperature_ > t.temp_user_max, kStatusTempOverUser, {});
  threshold(ev, temperature_ < t.temp_user_min, kStatusTempUnderUser, {});
  threshold(ev, temperature_ > t.temp_factory_max, kStatusTempOverFactory, {0x4210, 1, 1, Level::warning, true});
  threshold(ev, temperature_ < t.temp_factory_min, kStatusTempUnderFactory, {0x4210, 1, 2, Level::warning, true});
  threshold(ev, voltage_ > t.volt_user_max, kStatusVoltOverUser, {});
  threshold(ev, voltage_ < t.volt_user_min, kStatusVoltUnderUser, {});
  threshold(ev, voltage_ > t.volt_factory_max, kStatusVoltOverFactory, {0x3100, 1, 1, Level::warning, true});
  threshold(ev, voltage_ < t.volt_factory_min, kStatusVoltUnderFactory, {0x3100, 1, 2, Level::warning, true});

  // Maintenance: time since maintenance (0.1 h) reached 0x230A hours (E§4.3 0x230A, E§5.8).
  const bool due = maintenance_hours != 0 &&
                   static_cast<std::uint64_t>(history_.time_since_maintenance) >=
                       static_cast<std::uint64_t>(maintenance_hours) * 10U;
  threshold(ev, due, kStatusMaintenance, {0x5000, 0, 1, Level::info, true});
  return ev;
}

std::uint32_t ConditionMonitor::reset_command(std::uint8_t sub) noexcept {
  switch (sub) {
    case 1:  // Reset Maintenance: every "since maintenance" value
      history_.boot_since_maintenance = 0;
      history_.time_since_maintenance = 0;
      history_.lot_since_maintenance = 0;
      history_.odometer_since_maintenance = 0;
      history_.temperature.maintenance.clear();
      history_.voltage.maintenance.clear();
      return abort_code::kOk;
    case 2: history_.lot_since_reset = 0; return abort_code::kOk;
    case 3: history_.temperature.since_reset.clear_min(); return abort_code::kOk;
    case 4: history_.temperature.since_reset.clear_max(); return abort_code::kOk;
    case 5: history_.voltage.since_reset.clear_min(); return abort_code::kOk;
    case 6: history_.voltage.since_reset.clear_max(); return abort_code::kOk;
    default: return abort_code::kSubIndexDoesNotExist;
  }
}

}  // namespace cobridge::sim
