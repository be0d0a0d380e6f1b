// PositionPipeline: from the simulated shaft angle (turns) to the position and
// speed values one encoder channel reports, per family.
//
// Stages, every 1 ms measuring cycle (J§1.2.3/§1.2.4, E§3.3):
//   shaft turns (+ mount offset) -> moving average / position filter
//   -> physical count = floor(turns x steps_per_rev)
//   -> counting direction (0x6000 bit 0; ccw mirrors: total-1-count, J§1.4.1)
//   -> family range: rotary and ifm wrap modulo the physical total; the
//      multiturn does not wrap and runs the out-of-range model (E§9.1, C.7.4)
//   -> scaling (0x6001/0x6002): count x units / physical_units, mod total range
//   -> preset/offset (CiA 406: writing P makes the current position read P)
//   -> error sentinels (J 0x7FF0; E 0x7FFFFFFC / 0x7FFFFFF8 / 0x80000008)
//   -> ifm limit-switch bits 30/31 (F§7.4 0x2104/0x2105).
// Speed is computed from the unfiltered or filtered angle per family, signed
// like the counting direction, saturated to INTEGER16.
//
// `settings()` holds the object-dictionary values the pipeline reads; the
// device's write hooks validate a value with the `check_*` helpers (they
// return a CiA 301 abort code, 0 = ok) and then store it in settings().
// `update` is noexcept and allocation-free (fixed ring buffer).
// Thread: owned by the simulator's bus thread; not thread-safe.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "families/family.hpp"

namespace cobridge::sim {

// The family identity of daemon/families (the simulator's device library uses it too).
using families::FamilyId;

struct Resolution {
  std::uint32_t steps_per_rev = 0;  // 0x6501
  std::uint32_t revolutions = 1;    // 0x6502
  [[nodiscard]] constexpr std::uint64_t total() const noexcept {
    return static_cast<std::uint64_t>(steps_per_rev) * revolutions;
  }
};

// Physical resolution per family: rotary 0x4000 x 1 (14 bit, J§1.2.3, 0x6501/0x6502);
// multiturn 0x10000 x 44 = 0x2C0000 (E§4.2); ifm "see label" (F§7.5), default
// 4096 x 4096 (12 bit x 12 bit; 0x2102 default 0x1000000 = 4096 x 4096, F§7.4).
[[nodiscard]] Resolution physical_resolution(FamilyId family) noexcept;

// Preset semantics (J§1.3.2 0x6010, CiA 406).
enum class PresetMode : std::uint8_t {
  current_reads_preset,  // CiA 406: offset = P - current position (default, all families)
  offset_added,          // J§1.4.6.1 hint: output range is [P, P + total range)
};

// Multiturn out-of-range state (E§9.1, E§10.1).
enum class RangeState : std::uint8_t {
  in_range,
  info_over,      // within the last revolution below the upper limit (0x1002 bit 10)
  info_under,     // within the first revolution above the lower limit (0x1002 bit 11)
  warning_over,   // beyond the upper limit by <= warning margin; position 0x7FFFFFF8
  warning_under,  // beyond the lower limit by <= warning margin; position 0x80000008
  error_over,     // latched until back in range and 0x2100 written; 0x7FFFFFF8
  error_under,    // latched likewise; 0x80000008
};

// 0x1002 / 0x6503 / 0x6505 bits for a multiturn range state (E§10.1-10.3).
struct RangeStatusBits {
  std::uint32_t status_1002 = 0;
  std::uint16_t alarms_6503 = 0;
  std::uint16_t warnings_6505 = 0;
};
[[nodiscard]] RangeStatusBits range_status_bits(RangeState state) noexcept;


struct PositionSettings {
  FamilyId family = FamilyId::novotechnik_rotary;
  Resolution physical{};
  // 0x6000 bit 2 polarity (E§5.3): J 1 = on, E 0 = on (as printed), F 1 = on.
  bool scaling_bit_active_high = true;
  PresetMode preset_mode = PresetMode::current_reads_preset;
  // Shaft angle added before counting: where in the physical range turn 0 of
  // the motion lies (a multiturn mounted mid-range uses e.g. 22.0).
  double mount_offset_turns = 0.0;
  // Multiturn: counts beyond a limit still reported as Warning; beyond that
  // the Error latches (E§9.1, E§10.1; default one revolution).
  std::uint32_t warning_margin = 0;

  // Object-dictionary values.
  std::uint16_t operating_parameter = 0;  // 0x6000 (F: bit 0 shared with 0x2100 bit 0)
  std::uint32_t units_per_rev = 0;        // 0x6001
  std::uint32_t total_range = 0;          // 0x6002
  std::uint8_t position_filter = 0;       // E 0x2010/1: 2^n samples (J uses 0x6000 bits 14..12)
  std::uint16_t speed_integration_ms = 1; // E 0x6031/2
  bool speed_enabled = true;              // F 0x3010/1 (factory: off); always on for J, E
  std::uint8_t speed_mode = 0;            // F 0x3010/2: 0 = 5 ms, 1 = 50 ms, 2 = 500 ms
  bool limit_min_enabled = false;         // F 0x2100 bit 1
  bool limit_max_enabled = false;         // F 0x2100 bit 2
  std::uint32_t limit_min = 0;            // F 0x2104 (linked to 0x6401)
  std::uint32_t limit_max = 0;            // F 0x2105 (linked to 0x6402)

  // Factory defaults of a family (OD defaults of J§1.3.2, E§4.2, F§7.4/§7.5).
  [[nodiscard]] static PositionSettings defaults(FamilyId family) noexcept;
  [[nodiscard]] static PositionSettings defaults(FamilyId family, Resolution physical) noexcept;
};

// What one measuring cycle produces.
struct PositionSample {
  // Wire bits of the position object (J 0x6020/ch and E 0x6004 INTEGER32,
  // F 0x6004 UNSIGNED32 with limit-switch bits): a sentinel on error.
  std::uint32_t position = 0;
  // The position value without sentinels and limit bits, for CAM and work
  // area evaluation; not meaningful when `error_value` is set (the manuals
  // keep CAM and work-area states unchanged then, J§1.8.1, E§9.1 0x5000).
  std::int64_t value = 0;
  std::uint32_t raw = 0;   // E 0x600C: count without scaling and preset
  std::int16_t speed = 0;  // 0x6030/1: J, E 0.1 deg/s; F digits/s
  std::int32_t speed32 = 0;  // F 0x3011 (modelled 32-bit, F§7.4 0x3011)
  bool speed_saturated = false;  // E: 0x1002 bit 19, 0x6505 bit 6
  bool error_value = false;      // position is a sentinel, speed forced to 0
  RangeState range = RangeState::in_range;
};

class PositionPipeline {
 public:
  explicit PositionPipeline(PositionSettings settings) noexcept;

  [[nodiscard]] PositionSettings& settings() noexcept { return settings_; }
  [[nodiscard]] const PositionSettings& settings() const noexcept { return settings_; }

  // One measuring cycle: the shaft angle and the time it was taken (seconds,
  // monotonic). Repeated calls with the same time are treated as one sample.
  PositionSample update(double shaft_turns, double seconds) noexcept;
  [[nodiscard]] const PositionSample& last() const noexcept { return last_; }

  // Preset write (J 0x6010/ch, E 0x6003, F 0x6003/0x2103) against the last
  // sample; returns an abort code (check_preset). The next update reads P.
  [[nodiscard]] std::uint32_t preset(std::int64_t p) noexcept;
  [[nodiscard]] std::int64_t preset_value() const noexcept { return preset_; }
  // Offset value 0x6509 (E, F); also what the device keeps in non-volatile memory.
  [[nodiscard]] std::int64_t offset() const noexcept { return offset_; }
  void restore_offset(std::int64_t offset, std::int64_t preset) noexcept;

  // E 0x2100 Position Error Reset: clears a latched out-of-range error when
  // the position is back in range. Returns true if an error was cleared.
  bool position_error_reset() noexcept;
  // Injected measurement / sensor error (J 0x5000 -> 0x7FF0; E 0x5051/1/0 -> 0x7FFFFFFC).
  void set_measurement_error(bool on) noexcept { measurement_error_ = on; }
  [[nodiscard]] bool measurement_error() const noexcept { return measurement_error_; }

  // Derived from the settings.
  [[nodiscard]] bool scaling_active() const noexcept;
  [[nodiscard]] bool counting_ccw() const noexcept { return (settings_.operating_parameter & 1U) != 0; }
  [[nodiscard]] unsigned filter_exponent() const noexcept;  // n of the 2^n moving average
  // Units per revolution and total range of the output (physical when scaling is off).
  [[nodiscard]] std::uint64_t output_units_per_rev() const noexcept;
  [[nodiscard]] std::uint64_t output_total() const noexcept;

  // Forget the sample history and latches (power cycle, NMT reset of the model).
  void reset_history() noexcept;

 private:
  struct Point {
    double seconds;
    double turns;
  };
  static constexpr std::size_t kHistory = 1024;  // > 500 ms ifm window at 1 ms

  [[nodiscard]] const Point& back(std::size_t age) const noexcept;  // 0 = newest
  [[nodiscard]] double filtered_turns() const noexcept;
  void push_history(double shaft_turns, double seconds) noexcept;
  void set_speed(PositionSample& out) const noexcept;  // speed, speed32, speed_saturated
  // Whether the sample reads an error value, and which (J§1.8, E§9.1); ifm
  // leaves `sentinel` alone (F documents none).
  [[nodiscard]] bool error_value(RangeState range, std::uint32_t& sentinel) const noexcept;
  [[nodiscard]] double speed_turns_per_s() const noexcept;
  [[nodiscard]] std::int64_t scale(std::int64_t count) const noexcept;
  [[nodiscard]] std::int64_t apply_offset(std::int64_t scaled) const noexcept;
  [[nodiscard]] RangeState classify(std::int64_t count) noexcept;
  [[nodiscard]] std::uint32_t encode(std::int64_t value) const noexcept;

  PositionSettings settings_;
  std::array<Point, kHistory> history_{};
  std::size_t head_ = 0;   // index of the newest point
  std::size_t count_ = 0;  // valid points
  std::int64_t scaled_ = 0;  // last scaled value before the offset
  bool have_scaled_ = false;
  std::int64_t offset_ = 0;
  std::int64_t preset_ = 0;
  bool measurement_error_ = false;
  RangeState latched_ = RangeState::in_range;  // error_over / error_under or in_range
  std::int64_t last_count_ = 0;  // directed physical count of the last cycle
  PositionSample last_{};
};

// ---- Validation helpers for object-dictionary write hooks (0 = ok) ----

// 0x6000 write to 0x6001/0x6002 allowed? 0x08000022 when scaling is off per
// the family polarity (J§1.4.2, E§5.4).
[[nodiscard]] std::uint32_t check_scaling_write_allowed(const PositionSettings& s,
                                                        std::uint16_t operating_parameter) noexcept;
// 0x6001: 1..physical steps per revolution (J§1.4.2, E§5.4 "can only be reduced").
[[nodiscard]] std::uint32_t check_units_per_rev(const PositionSettings& s, std::uint32_t value) noexcept;
// 0x6002: 1..physical total (J§1.4.3, E§5.5).
[[nodiscard]] std::uint32_t check_total_range(const PositionSettings& s, std::uint32_t value) noexcept;
// 0x6001 <-> 0x6002 coupling (J§1.4.2, E§5.4): total = units x revolutions.
[[nodiscard]] std::uint32_t coupled_total_range(const PositionSettings& s, std::uint32_t units_per_rev) noexcept;
[[nodiscard]] std::uint32_t coupled_units_per_rev(const PositionSettings& s, std::uint32_t total_range) noexcept;
// Preset must be a value of the output range (F§7.4 0x2103: must not exceed
// the total resolution); 0x06090030 otherwise. Negative values are allowed
// for the INTEGER32 rotary preset in offset_added mode only.
[[nodiscard]] std::uint32_t check_preset(const PositionPipeline& p, std::int64_t value) noexcept;
// J 0x6000 bits 14..12 = 0..7 always fit; E 0x2010/1: 0..7 (E§5.1).
[[nodiscard]] std::uint32_t check_position_filter(std::uint8_t n) noexcept;
// E 0x2010/2: 0..8; E 0x6031/2: 0, 1, 2, 3, 6, 12, 25 ms (E§5.2).
[[nodiscard]] std::uint32_t check_speed_filter(std::uint8_t f) noexcept;
[[nodiscard]] std::uint32_t check_speed_integration_ms(std::uint16_t ms) noexcept;
// The E§5.2 coupling table: writing one object sets the other.
[[nodiscard]] std::uint16_t integration_ms_for_speed_filter(std::uint8_t f) noexcept;
[[nodiscard]] std::uint8_t speed_filter_for_integration_ms(std::uint16_t ms) noexcept;
// F 0x3010/2: 0..2.
[[nodiscard]] std::uint32_t check_ifm_speed_mode(std::uint8_t mode) noexcept;
// F 0x2101: desired resolution per revolution AU, 1..PAU ("not transferred" above).
[[nodiscard]] std::uint32_t check_ifm_resolution_per_rev(const PositionSettings& s, std::uint32_t au) noexcept;
// F 0x2102 total resolution GA for the current AU: 1..PGA; GA = PGA x AU / PAU
// when `require_formula`; below PGA it must be a multiple of PAU (F§7.4, as printed).
[[nodiscard]] std::uint32_t check_ifm_total_resolution(const PositionSettings& s, std::uint32_t ga,
                                                       std::uint32_t au, bool require_formula = true) noexcept;
[[nodiscard]] std::uint32_t ifm_total_resolution_for(const PositionSettings& s, std::uint32_t au) noexcept;
// F 0x2104/0x2105: must not exceed the physical total resolution (F§7.4).
[[nodiscard]] std::uint32_t check_ifm_limit_switch(const PositionSettings& s, std::uint32_t value) noexcept;

}  // namespace cobridge::sim
