// Novotechnik multiturn series MZ1-2200 / MC1-2800 / MB1-3600 (manual E).
// What E adds: position 0x6004 (INTEGER32) with the hidden alias 0x6020/1
// the default mapping names (E§4.1), raw position 0x600C, preset 0x6003,
// inverted scaling bit (E§5.3 as printed), the E§9.1 EMCY table with its
// levels (filtered by 0x2104 in EmcyProducer), the 32-bit error position
// values, latched out-of-range errors reset by 0x2100 (E§4.3), 0x1029
// error behaviour, 0x1002 (E§10.1), 0x6503 (E§10.2), the 0x2010/2 <->
// 0x6031/2 coupling (E§5.2).
#include <algorithm>
#include <chrono>
#include <optional>

#include "canopen/emcy.hpp"
#include "families/novotechnik.hpp"
#include "families/novotechnik_multiturn.hpp"
#include "device/sim_device_impl.hpp"

namespace cobridge::sim {

namespace {

using canopen::Emcy;
using families::EmcyLevel;

constexpr std::int16_t kNominalTemperature = 350;  // 35.0 degC internal
constexpr std::uint16_t kNominalVoltage = 240;     // 24.0 V

// History values kept in NV under their own OD keys; min/max carry their
// "has a value" flag in bit 32.
std::uint64_t pack(const MinMax& m, bool max) noexcept {
  const std::int32_t v = max ? m.max : m.min;
  const bool has = max ? m.has_max : m.has_min;
  return static_cast<std::uint32_t>(v) | (has ? (std::uint64_t{1} << 32) : 0U);
}
void unpack(MinMax& m, bool max, std::optional<std::uint64_t> raw) noexcept {
  if (!raw) return;
  const auto v = static_cast<std::int32_t>(static_cast<std::uint32_t>(*raw));
  const bool has = (*raw >> 32) != 0;
  if (max) {
    m.max = v;
    m.has_max = has;
  } else {
    m.min = v;
    m.has_min = has;
  }
}

constexpr std::uint32_t kErrorPositionFaults =
    fault_bit(FaultKind::measurement_error) | fault_bit(FaultKind::hardware_fault);

std::uint8_t speed_filter_for(std::uint64_t integration_ms) noexcept {
  switch (integration_ms) {  // E§5.2 table; 0 -> 0 and 1 -> 3 where not unique (E§5.2)
    case 0: return 0;
    case 1: return 3;
    case 2: return 4;
    case 3: return 5;
    case 6: return 6;
    case 12: return 7;
    default: return 8;
  }
}

std::uint16_t integration_for(std::uint64_t filter) noexcept {
  constexpr std::array<std::uint16_t, 9> kMs{0, 0, 1, 1, 2, 3, 6, 12, 25};
  return kMs[std::min<std::uint64_t>(filter, 8)];
}

}  // namespace

void SimDevice::Impl::multiturn_factory() {
  factory[NvImage::key(0x2000, 0)] = factory_node;
  factory[NvImage::key(0x2001, 0)] = factory_kbit;
  revision = 0x00010003;  // E§4.1 "e.g. 0x10003"
  factory[NvImage::key(0x1018, 3)] = revision;
  factory[NvImage::key(0x6507, 0)] = 0x01020302;
  // "Per data sheet" thresholds (E§4.3), in 0.1 degC and 0.1 V.
  factory[NvImage::key(0x235A, 1)] = static_cast<std::uint16_t>(-300);
  factory[NvImage::key(0x235A, 2)] = 850;
  factory[NvImage::key(0x235B, 1)] = static_cast<std::uint16_t>(-400);
  factory[NvImage::key(0x235B, 2)] = 1050;
  factory[NvImage::key(0x236A, 1)] = 90;
  factory[NvImage::key(0x236A, 2)] = 320;
  factory[NvImage::key(0x236B, 1)] = 80;
  factory[NvImage::key(0x236B, 2)] = 340;
  factory[NvImage::key(0x234A, 0)] = 1;
}

void SimDevice::Impl::multiturn_extras() {
  // E§4.1: the documented default mapping 0x60200120 names an
  // object E does not list; the device answers it as the position.
  canopen::EntryDef def;
  def.index = 0x6020;
  def.sub = 1;
  def.type = canopen::DataType::kInteger32;
  def.access = canopen::Access::kRo;
  def.pdo_mappable = true;
  def.name = "Position value (alias of 0x6004)";
  (void)od->insert(def);
}

std::uint32_t SimDevice::Impl::multiturn_on_write(const canopen::WriteRequest& req) {
  using namespace canopen::od_abort;
  switch (req.index) {
    case 0x6001:
    case 0x6002:
      return novotechnik_scaling_write(req);
    case 0x2001: {
      const std::uint64_t v = req.as_unsigned();  // E§3.1 ordering-code rates
      return v == 50 || v == 125 || v == 250 || v == 500 || v == 800 || v == 1000 ? 0 : kValueRangeExceeded;
    }
    case 0x6031:
      if (req.sub == 2) {
        const std::uint64_t v = req.as_unsigned();  // E§5.2 table values
        return v == 0 || v == 1 || v == 2 || v == 3 || v == 6 || v == 12 || v == 25 ? 0 : kValueRangeExceeded;
      }
      return 0;
    case 0x6003:
      return encoder.check_preset(0, static_cast<std::int64_t>(req.as_unsigned()));
    case 0x2300:
      // E§4.3, E§5.8: the only commands that clear the history recorder.
      if (req.sub == 0 || req.as_unsigned() == 0) return 0;
      if (const std::uint32_t r = condition.reset_command(req.sub)) return r;
      condition_publish();
      condition_persist();
      return 0;
    default:
      return 0;
  }
}

void SimDevice::Impl::multiturn_after_write(std::uint16_t index, std::uint8_t sub) {
  switch (index) {
    case 0x6001:
    case 0x6002:
      novotechnik_scaling_after(index);
      return;
    case 0x6003:
      encoder.preset(0, static_cast<std::int64_t>(od->get_raw(0x6003, 0).value_or(0)));
      return;
    case 0x2010:
      if (sub == 2) (void)od->set_u16(0x6031, 2, integration_for(od->get_u8(0x2010, 2).value_or(3)));
      return;
    case 0x6031:
      if (sub == 2) (void)od->set_u8(0x2010, 2, speed_filter_for(od->get_raw(0x6031, 2).value_or(1)));
      return;
    case 0x2100: {
      // E§4.3 Position Error Reset: clears a latched out-of-range error once
      // the sensor is back in range, then EMCY 0x0000 "valid position".
      const bool over_gone = (faults & fault_bit(FaultKind::over_range)) == 0;
      const bool under_gone = (faults & fault_bit(FaultKind::under_range)) == 0;
      const bool had = over_range_latched || under_range_latched;
      if (over_gone) over_range_latched = false;
      if (under_gone) under_range_latched = false;
      const bool natural = encoder.position_error_reset();
      if ((had && !over_range_latched && !under_range_latched) || natural) {
        refresh_status();
        send_emcy(Emcy{}, EmcyLevel::hard);
      }
      return;
    }
    default:
      return;
  }
}

void SimDevice::Impl::multiturn_publish(ChannelSample& s, const ChannelSample& before, bool first) {
  // Injected range errors force the E§9.1 values; a measurement / hardware
  // error comes from the pipeline (0x7FFFFFFC) like the range of the motion.
  if (!s.error_value && over_range_latched) {
    s.position_bits = static_cast<std::uint32_t>(families::kMultiturnOverflowPosition);
    s.speed = 0;
    s.error_value = true;
  } else if (!s.error_value && under_range_latched) {
    s.position_bits = static_cast<std::uint32_t>(families::kMultiturnUnderflowPosition);
    s.speed = 0;
    s.error_value = true;
  }
  if (s.error_value && !first) {
    s.cams = before.cams;  // E§9.1 0x5000: CAM and work-area states unchanged
    s.work_area = before.work_area;
  }
  const auto position = static_cast<std::int32_t>(s.position_bits);
  (void)od->set_i32(0x6004, 0, position);
  (void)od->set_i32(0x6020, 1, position);
  (void)od->set_u32(0x600C, 0, s.raw);
  (void)od->set_i16(0x6030, 1, static_cast<std::int16_t>(std::clamp<std::int32_t>(s.speed, -32768, 32767)));
  (void)od->set_u8(0x6300, 1, s.cams);
  (void)od->set_u8(0x6400, 1, s.work_area);
  (void)od->set_i32(0x6509, 0, static_cast<std::int32_t>(encoder.offset(0)));
  if (first) return;
  const bool range_changed = s.range != before.range;
  if (range_changed || s.speed_saturated != before.speed_saturated) {
    // The status bits are computed from last[0]; the caller stores the
    // sample only after this returns, so store it first.
    last[0] = s;
    refresh_status();
  }
  if (range_changed) {
    // E§9.1 0x5051 rows for the range model of the motion.
    switch (s.range) {
      case RangeState::warning_over: send_emcy(Emcy{0x5051, 2, {1, 0, 0, 0, 0}}, EmcyLevel::warn); break;
      case RangeState::warning_under: send_emcy(Emcy{0x5051, 2, {2, 0, 0, 0, 0}}, EmcyLevel::warn); break;
      case RangeState::error_over: send_emcy(Emcy{0x5051, 1, {1, 0, 0, 0, 0}}, EmcyLevel::error); break;
      case RangeState::error_under: send_emcy(Emcy{0x5051, 1, {2, 0, 0, 0, 0}}, EmcyLevel::error); break;
      case RangeState::in_range:
        if (before.range == RangeState::warning_over || before.range == RangeState::warning_under)
          send_emcy(Emcy{0x5051, 0, {0, 0, 0, 0, 0}}, EmcyLevel::hard);  // "valid position"
        break;
      default: break;
    }
  }
  if (s.cams != before.cams)
    send_emcy(Emcy{families::kNovotechnikCamEmcy, 1,
                   families::multiturn_cam_emcy_bytes(static_cast<std::uint8_t>(s.cams ^ before.cams), s.cams)},
              EmcyLevel::warn);
  if (s.work_area != before.work_area)
    send_emcy(Emcy{families::kNovotechnikWorkAreaEmcy, 1,
                   families::multiturn_work_area_emcy_bytes(s.work_area)},
              EmcyLevel::warn);
}

void SimDevice::Impl::multiturn_fault(FaultKind fault, TimePoint now) {
  if (fault == FaultKind::clear) {
    const std::uint32_t before = faults;
    faults = 0;
    encoder.set_measurement_error(false);
    condition.set_temperature(kNominalTemperature);
    condition.set_voltage(kNominalVoltage);
    // Latched range errors stay until 0x2100 (E§4.3); everything else ends
    // with EMCY 0x0000 "sensor error reset" (E§9.1).
    const std::uint32_t range = fault_bit(FaultKind::over_range) | fault_bit(FaultKind::under_range);
    if ((before & ~range) != 0) {
      refresh_status();
      send_emcy(Emcy{}, EmcyLevel::hard);
    }
    return;
  }
  if (fault == FaultKind::channel_disagreement || (faults & fault_bit(fault)) != 0) return;
  faults |= fault_bit(fault);
  if (fault == FaultKind::measurement_error || fault == FaultKind::hardware_fault) encoder.set_measurement_error(true);
  refresh_status();  // the EMCY carries the new error register
  switch (fault) {
    case FaultKind::measurement_error: {
      send_emcy(Emcy{0x5051, 1, {0, 0, 0, 0, 0}}, EmcyLevel::error);
      // E§4.1 0x1029/2: NMT reaction to a measurement error.
      const auto t = nmt.apply_error_behaviour(od->get_u8(0x1029, 2).value_or(0));
      if (t.outcome == canopen::NmtOutcome::state_changed) on_nmt_change(t.from, now);
      return;
    }
    case FaultKind::over_range:
      over_range_latched = true;
      send_emcy(Emcy{0x5051, 1, {1, 0, 0, 0, 0}}, EmcyLevel::error);
      return;
    case FaultKind::under_range:
      under_range_latched = true;
      send_emcy(Emcy{0x5051, 1, {2, 0, 0, 0, 0}}, EmcyLevel::error);
      return;
    case FaultKind::hardware_fault: send_emcy(Emcy{0x5000, 1, {0, 0, 0, 0, 0}}, EmcyLevel::hard); return;
    // The live value leaves the factory band; the condition monitor raises
    // EMCY 0x4210/1/x or 0x3100/1/x and the 0x1002 bits on the next cycle.
    case FaultKind::temperature_high:
      condition.set_temperature(static_cast<std::int16_t>(condition.thresholds.temp_factory_max + 50));
      return;
    case FaultKind::temperature_low:
      condition.set_temperature(static_cast<std::int16_t>(condition.thresholds.temp_factory_min - 50));
      return;
    case FaultKind::voltage_high:
      condition.set_voltage(static_cast<std::uint16_t>(condition.thresholds.volt_factory_max + 20));
      return;
    case FaultKind::voltage_low:
      condition.set_voltage(static_cast<std::uint16_t>(condition.thresholds.volt_factory_min - 10));
      return;
    default: return;
  }
}

void SimDevice::Impl::multiturn_life_guarding(bool lost) {
  if (!lost) return;
  // E§9.1 0x5000 / 0 / 0 "LifeGuarding error", level Info; reaction 0x1029/1.
  send_emcy(Emcy{0x5000, 0, {0, 0, 0, 0, 0}}, EmcyLevel::info);
  const auto t = nmt.apply_error_behaviour(od->get_u8(0x1029, 1).value_or(0));
  if (t.outcome == canopen::NmtOutcome::state_changed) on_nmt_change(t.from, now_cache);
}

void SimDevice::Impl::multiturn_status() noexcept {
  auto has = [this](FaultKind k) { return (faults & fault_bit(k)) != 0; };
  std::uint32_t st = 0;  // E§10.1
  st |= condition.status_bits();  // bits 2..9, 25
  if (over_range_latched) st |= 1U << 12;
  if (under_range_latched) st |= 1U << 13;
  if (has(FaultKind::measurement_error)) st |= 1U << 22;
  if (life_guarding_lost) st |= 1U << 24;
  if (faults == 0 && !over_range_latched && !under_range_latched && last[0].range == RangeState::in_range)
    st |= 1U << 26;  // valid position
  if (has(FaultKind::hardware_fault)) st |= 1U << 31;
  // E§10.1 bit 19 "speed out of range", E§10.3 bit 6 "speed range limit":
  // 0x6030/1 is saturated at the INTEGER16 limit (E§3.4 unit 0.1 deg/s,
  // so above 3276.7 deg/s). E§9.1 has no EMCY row for it.
  const bool speed_limit = last[0].speed_saturated;
  if (speed_limit) st |= 1U << 19;
  status = st;
  std::uint16_t al = 0;  // E§10.2
  if (has(FaultKind::measurement_error)) al |= 1U << 0;
  if (has(FaultKind::hardware_fault)) al |= 1U << 1;
  if (under_range_latched) al |= 1U << 12;
  if (over_range_latched) al |= 1U << 13;
  const RangeStatusBits r = range_status_bits(last[0].range);
  status = st | r.status_1002;
  alarms = static_cast<std::uint16_t>(al | r.alarms_6503);
  warnings = static_cast<std::uint16_t>(r.warnings_6505 | condition.warning_bits() | (speed_limit ? 1U << 6 : 0U));
}

void SimDevice::Impl::condition_power_up(TimePoint now) {
  ConditionHistory h;
  const NvImage& img = nv_data.history;
  h.boot_since_maintenance = static_cast<std::uint32_t>(img.get(0x2310, 1).value_or(0));
  h.boot_total = static_cast<std::uint32_t>(img.get(0x2310, 2).value_or(0));
  h.time_since_maintenance = static_cast<std::uint32_t>(img.get(0x2320, 2).value_or(0));
  h.time_total = static_cast<std::uint32_t>(img.get(0x2320, 3).value_or(0));
  h.lot_since_reset = static_cast<std::uint32_t>(img.get(0x2330, 2).value_or(0));
  h.lot_since_maintenance = static_cast<std::uint32_t>(img.get(0x2330, 3).value_or(0));
  h.lot_total = static_cast<std::uint32_t>(img.get(0x2330, 4).value_or(0));
  h.odometer_since_maintenance = static_cast<std::uint32_t>(img.get(0x2340, 2).value_or(0));
  h.odometer_total = static_cast<std::uint32_t>(img.get(0x2340, 3).value_or(0));
  for (std::uint16_t index : {std::uint16_t{0x2350}, std::uint16_t{0x2360}}) {
    Tracker& t = index == 0x2350 ? h.temperature : h.voltage;
    unpack(t.since_reset, false, img.get(index, 4));
    unpack(t.since_reset, true, img.get(index, 5));
    unpack(t.maintenance, false, img.get(index, 6));
    unpack(t.maintenance, true, img.get(index, 7));
    unpack(t.lifetime, false, img.get(index, 8));
    unpack(t.lifetime, true, img.get(index, 9));
  }
  condition.restore(h);
  condition.set_temperature(kNominalTemperature);
  condition.set_voltage(kNominalVoltage);
  condition.power_up();  // E§5.8: boot counters +1, "power-on" values 0
  condition_configure();
  last_condition_update = now;
  condition_persist();
  condition_publish();
}

void SimDevice::Impl::condition_configure() noexcept {
  ConditionThresholds& t = condition.thresholds;
  t.temp_user_min = od->get_i16(0x235A, 1).value_or(t.temp_user_min);
  t.temp_user_max = od->get_i16(0x235A, 2).value_or(t.temp_user_max);
  t.temp_factory_min = od->get_i16(0x235B, 1).value_or(t.temp_factory_min);
  t.temp_factory_max = od->get_i16(0x235B, 2).value_or(t.temp_factory_max);
  t.volt_user_min = od->get_u16(0x236A, 1).value_or(t.volt_user_min);
  t.volt_user_max = od->get_u16(0x236A, 2).value_or(t.volt_user_max);
  t.volt_factory_min = od->get_u16(0x236B, 1).value_or(t.volt_factory_min);
  t.volt_factory_max = od->get_u16(0x236B, 2).value_or(t.volt_factory_max);
  condition.lot_size_config = od->get_u8(0x233A, 0).value_or(0);
  condition.maintenance_hours = od->get_u32(0x230A, 0).value_or(0xFFFF);
}

void SimDevice::Impl::condition_cycle(const ChannelSample& s, TimePoint now) {
  const double dt = std::chrono::duration<double>(now - last_condition_update).count();
  last_condition_update = now;
  const ConditionEvents ev = condition.update(dt, s.shaft_turns, s.cam_active);
  condition_publish();
  if (ev.count > 0) refresh_status();
  for (std::uint8_t i = 0; i < ev.count; ++i) {
    const ConditionEvent& e = ev.items[i];
    if (!e.active) continue;  // E§9.1 has no "condition ended" rows for these
    send_emcy(Emcy{e.code, e.byte2, {e.byte3, 0, 0, 0, 0}},
              e.level == ConditionEvent::Level::info ? EmcyLevel::info : EmcyLevel::warn);
  }
  // The recorder is written when the operating-time counter moves (every
  // 0.1 h), so a power loss costs at most one tick, as on a real device.
  if (condition.history().time_total != persisted_time_total) condition_persist();
}

void SimDevice::Impl::condition_publish() noexcept {
  const ConditionHistory& h = condition.history();
  (void)od->set_i16(0x2002, 0, condition.temperature());
  (void)od->set_u16(0x2003, 0, condition.voltage());
  (void)od->set_u32(0x2310, 1, h.boot_since_maintenance);
  (void)od->set_u32(0x2310, 2, h.boot_total);
  (void)od->set_u32(0x2320, 1, condition.time_since_power_on());
  (void)od->set_u32(0x2320, 2, h.time_since_maintenance);
  (void)od->set_u32(0x2320, 3, h.time_total);
  (void)od->set_u32(0x6508, 0, h.time_total);
  (void)od->set_u32(0x2330, 1, condition.lot_since_power_on());
  (void)od->set_u32(0x2330, 2, h.lot_since_reset);
  (void)od->set_u32(0x2330, 3, h.lot_since_maintenance);
  (void)od->set_u32(0x2330, 4, h.lot_total);
  (void)od->set_u32(0x2340, 1, condition.odometer_since_power_on());
  (void)od->set_u32(0x2340, 2, h.odometer_since_maintenance);
  (void)od->set_u32(0x2340, 3, h.odometer_total);
  (void)od->set_i16(0x2350, 1, condition.temperature());
  (void)od->set_u16(0x2360, 1, condition.voltage());
  const auto put = [this](std::uint16_t index, std::uint8_t sub, const MinMax& m) {
    (void)set_raw(*od, index, sub, static_cast<std::uint64_t>(static_cast<std::uint32_t>(m.min)));
    (void)set_raw(*od, index, static_cast<std::uint8_t>(sub + 1), static_cast<std::uint64_t>(static_cast<std::uint32_t>(m.max)));
  };
  for (std::uint16_t index : {std::uint16_t{0x2350}, std::uint16_t{0x2360}}) {
    const Tracker& t = index == 0x2350 ? h.temperature : h.voltage;
    put(index, 2, t.power_on);
    put(index, 4, t.since_reset);
    put(index, 6, t.maintenance);
    put(index, 8, t.lifetime);
  }
}

void SimDevice::Impl::condition_persist() {
  const ConditionHistory& h = condition.history();
  NvImage& img = nv_data.history;
  img.set(0x2310, 1, h.boot_since_maintenance);
  img.set(0x2310, 2, h.boot_total);
  img.set(0x2320, 2, h.time_since_maintenance);
  img.set(0x2320, 3, h.time_total);
  img.set(0x2330, 2, h.lot_since_reset);
  img.set(0x2330, 3, h.lot_since_maintenance);
  img.set(0x2330, 4, h.lot_total);
  img.set(0x2340, 2, h.odometer_since_maintenance);
  img.set(0x2340, 3, h.odometer_total);
  for (std::uint16_t index : {std::uint16_t{0x2350}, std::uint16_t{0x2360}}) {
    const Tracker& t = index == 0x2350 ? h.temperature : h.voltage;
    img.set(index, 4, pack(t.since_reset, false));
    img.set(index, 5, pack(t.since_reset, true));
    img.set(index, 6, pack(t.maintenance, false));
    img.set(index, 7, pack(t.maintenance, true));
    img.set(index, 8, pack(t.lifetime, false));
    img.set(index, 9, pack(t.lifetime, true));
  }
  persisted_time_total = h.time_total;
  (void)persist();  // a failing disk loses the history, not the device
}

}  // namespace cobridge::sim
