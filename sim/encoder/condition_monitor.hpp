// ConditionMonitor: the condition-monitoring data of the multiturn series
// (E§4.3 0x2002/0x2003, 0x2300..0x236B, E§5.8).
//
// Live temperature (0.1 degC) and supply voltage (0.1 V) with min/max trackers
// over four windows (since power-on, since reset, since maintenance,
// lifetime), boot-cycle counter, operating time in 0.1 h ticks (0x232A = 6
// min), lot-size counter on CAM1/CAM2 edges selected by 0x233A, odometer in
// whole turns. E§5.8: the history is cleared by nothing but the 0x2300
// commands; a power cycle zeroes only the "since power-on" values.
// User thresholds (0x235A, 0x236A) set 0x1002 bits 2/3, 6/7; factory
// thresholds (0x235B, 0x236B) set bits 4/5, 8/9 and raise the warning EMCYs
// 0x4210/1/x and 0x3100/1/x; the maintenance interval 0x230A raises
// "maintenance required" (EMCY 0x5000/0/1, 0x1002 bit 25, 0x6505 bit 3).
// Nothing is sent from here: `update` returns the events and the device
// decides (NMT state, 0x2104 level filter) what goes on the bus.
//
// Time is passed in as a step; `time_scale` accelerates the operating-time
// clock for tests. `history()`/`restore()` carry what the device keeps in
// non-volatile memory.
// Thread: owned by the simulator's bus thread; update() is noexcept and
// allocation-free.
#pragma once

#include <array>
#include <cstdint>

namespace cobridge::sim {

// A min/max pair; reads 0/0 until the first sample after a reset ("reset to
// zero", E§4.3 0x2300; then re-seeded by the next live sample, E§4.3, E§5.8).
struct MinMax {
  std::int32_t min = 0;
  std::int32_t max = 0;
  bool has_min = false;
  bool has_max = false;
  void clear() noexcept { *this = MinMax{}; }
  void clear_min() noexcept { min = 0; has_min = false; }
  void clear_max() noexcept { max = 0; has_max = false; }
  void sample(std::int32_t v) noexcept;
};

// Four windows of one tracked quantity (0x2350/2..9, 0x2360/2..9).
struct Tracker {
  MinMax power_on;     // /2, /3
  MinMax since_reset;  // /4, /5
  MinMax maintenance;  // /6, /7
  MinMax lifetime;     // /8, /9
  void sample(std::int32_t v) noexcept;
};

// Values that survive a power cycle (the "history recorder", E§5.8).
struct ConditionHistory {
  Tracker temperature;  // power_on part is not persisted (cleared at power-up)
  Tracker voltage;
  std::uint32_t boot_since_maintenance = 0;  // 0x2310/1
  std::uint32_t boot_total = 0;              // 0x2310/2
  std::uint32_t time_since_maintenance = 0;  // 0x2320/2, 0.1 h
  std::uint32_t time_total = 0;              // 0x2320/3 (= 0x6508), 0.1 h
  std::uint32_t lot_since_reset = 0;         // 0x2330/2
  std::uint32_t lot_since_maintenance = 0;   // 0x2330/3
  std::uint32_t lot_total = 0;               // 0x2330/4
  std::uint32_t odometer_since_maintenance = 0;  // 0x2340/2, turns
  std::uint32_t odometer_total = 0;              // 0x2340/3
};

struct ConditionThresholds {
  // 0.1 degC / 0.1 V. E gives "per data sheet"; these defaults are an
  // [inference] for a 24 V industrial sensor, configurable per device.
  std::int16_t temp_user_min = -300;     // 0x235A/1
  std::int16_t temp_user_max = 850;      // 0x235A/2
  std::int16_t temp_factory_min = -400;  // 0x235B/1
  std::int16_t temp_factory_max = 1050;  // 0x235B/2
  std::uint16_t volt_user_min = 100;     // 0x236A/1
  std::uint16_t volt_user_max = 320;     // 0x236A/2
  std::uint16_t volt_factory_min = 80;   // 0x236B/1
  std::uint16_t volt_factory_max = 340;  // 0x236B/2
};

// An EMCY-worthy transition, coded as in E§9.1 (code, byte 2, byte 3).
struct ConditionEvent {
  enum class Level : std::uint8_t { info, warning };
  std::uint16_t code = 0;
  std::uint8_t byte2 = 0;
  std::uint8_t byte3 = 0;
  Level level = Level::warning;
  bool active = true;  // false: the condition has ended
};

struct ConditionEvents {
  std::array<ConditionEvent, 8> items{};
  std::uint8_t count = 0;
  void push(const ConditionEvent& e) noexcept {
    if (count < items.size()) items[count++] = e;
  }
};

// 0x1002 bits owned by condition monitoring (E§10.1).
inline constexpr std::uint32_t kStatusTempOverUser = 1U << 2;
inline constexpr std::uint32_t kStatusTempUnderUser = 1U << 3;
inline constexpr std::uint32_t kStatusTempOverFactory = 1U << 4;
inline constexpr std::uint32_t kStatusTempUnderFactory = 1U << 5;
inline constexpr std::uint32_t kStatusVoltOverUser = 1U << 6;
inline constexpr std::uint32_t kStatusVoltUnderUser = 1U << 7;
inline constexpr std::uint32_t kStatusVoltOverFactory = 1U << 8;
inline constexpr std::uint32_t kStatusVoltUnderFactory = 1U << 9;
inline constexpr std::uint32_t kStatusMaintenance = 1U << 25;
inline constexpr std::uint16_t kWarningMaintenance = 1U << 3;  // 0x6505 bit 3

class ConditionMonitor {
 public:
  ConditionMonitor() noexcept = default;

  // Settings the OD hooks write.
  ConditionThresholds thresholds;
  std::uint8_t lot_size_config = 0;        // 0x233A: 0 off, 1/2 CAM1 rising/falling, 3/4 CAM2
  std::uint32_t maintenance_hours = 0xFFFF;  // 0x230A, 0 = off
  double time_scale = 1.0;                 // operating-time acceleration (tests)

  // Power-up: boot counters +1 (0x2310), "power-on" values to 0 (E§5.8).
  void power_up() noexcept;

  // Live values (0x2002 = 0x2350/1, 0x2003 = 0x2360/1), set by the device or a fault.
  void set_temperature(std::int16_t tenth_degc) noexcept { temperature_ = tenth_degc; }
  void set_voltage(std::uint16_t tenth_volt) noexcept { voltage_ = tenth_volt; }
  [[nodiscard]] std::int16_t temperature() const noexcept { return temperature_; }
  [[nodiscard]] std::uint16_t voltage() const noexcept { return voltage_; }

  // One step: `dt_seconds` of real time, the shaft angle in turns and the CAM
  // active mask before polarity (bit 0 = CAM1).
  ConditionEvents update(double dt_seconds, double shaft_turns, std::uint8_t cam_active) noexcept;

  // 0x2300/1..6 reset commands; returns an abort code (0x06090011 for other subs).
  std::uint32_t reset_command(std::uint8_t sub) noexcept;

  // 0x1002 bits 2..9 and 25; 0x6505 bit 3.
  [[nodiscard]] std::uint32_t status_bits() const noexcept { return status_; }
  [[nodiscard]] std::uint16_t warning_bits() const noexcept {
    return (status_ & kStatusMaintenance) != 0 ? kWarningMaintenance : std::uint16_t{0};
  }

  // Read-outs.
  [[nodiscard]] const Tracker& temperature_tracker() const noexcept { return history_.temperature; }
  [[nodiscard]] const Tracker& voltage_tracker() const noexcept { return history_.voltage; }
  [[nodiscard]] std::uint32_t time_since_power_on() const noexcept { return time_power_on_; }  // 0x2320/1
  [[nodiscard]] std::uint32_t lot_since_power_on() const noexcept { return lot_power_on_; }    // 0x2330/1
  [[nodiscard]] std::uint32_t odometer_since_power_on() const noexcept { return odo_power_on_; }  // 0x2340/1
  [[nodiscard]] const ConditionHistory& history() const noexcept { return history_; }
  void restore(const ConditionHistory& h) noexcept;

 private:
  void tick_time() noexcept;
  void count_lot() noexcept;
  void count_turn() noexcept;
  void threshold(ConditionEvents& ev, bool now, std::uint32_t bit, const ConditionEvent& event) noexcept;

  ConditionHistory history_{};
  std::int16_t temperature_ = 350;  // 35.0 degC internal
  std::uint16_t voltage_ = 240;     // 24.0 V
  std::uint32_t time_power_on_ = 0;
  std::uint32_t lot_power_on_ = 0;
  std::uint32_t odo_power_on_ = 0;
  double seconds_fraction_ = 0.0;  // towards the next 0.1 h tick
  double turns_fraction_ = 0.0;    // towards the next whole turn
  double last_turns_ = 0.0;
  bool have_turns_ = false;
  std::uint8_t last_cams_ = 0;
  bool have_cams_ = false;
  std::uint32_t status_ = 0;
};

}  // namespace cobridge::sim
