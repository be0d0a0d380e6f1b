// Motion: the simulated shaft angle over time, parsed from a spec string.
//
// A simulated encoder measures a shaft that nobody turns, so the simulator
// needs a deterministic movement: `turns_at(seconds_since_start)` gives the
// shaft angle in turns (1.0 = one revolution), continuous and signed, which the
// position pipeline turns into counts. Grammar (`--device MODEL:motion=...`):
//
//   constant:<turns_per_s>                    steady rotation, may be negative
//   sine:<amplitude_turns>:<period_s>[:<offset_turns>]
//   steps:<t0>=<turns0>;<t1>=<turns1>;...     piecewise constant; seconds -> turns,
//                                             times strictly increasing, the first
//                                             value also holds before t0
//   ramp:<turns_per_s>:<max_turns>            triangle 0 -> max -> 0 -> ... (turns_per_s > 0;
//                                             a negative max ramps downwards)
//   script:<path>                             file of `time_s turns` lines, linear
//                                             interpolation, held before the first and
//                                             after the last line; '#' starts a comment
//
// `set_offset()` adds a constant angle, so a test can move the shaft by hand.
// Parsing allocates and may read a file (off the hot path); `turns_at` is
// noexcept and allocation-free (called every 1 ms measuring cycle).
// Thread: owned by the simulator's bus thread; not thread-safe.
#pragma once

#include "base/error.hpp"

#include <cstdint>
#include <string>
#include <string_view>
#include <system_error>
#include <type_traits>
#include <utility>
#include <vector>

namespace cobridge::sim {

enum class MotionError : std::uint8_t {
  ok = 0,
  empty_spec = 1,
  unknown_kind = 2,
  bad_number = 3,
  wrong_field_count = 4,
  bad_step = 5,
  not_increasing = 6,
  bad_period = 7,
  bad_ramp = 8,
  cannot_read_script = 9,
  bad_script_line = 10,
  empty_script = 11,
};

[[nodiscard]] const std::error_category& motion_category() noexcept;
[[nodiscard]] std::error_code make_error_code(MotionError e) noexcept;

// A parse outcome: on error `motion` is the default (constant:0) and `error`
// is set (kInvalidArgument, code a MotionError, the message names the
// offending part of the spec).
struct MotionParseResult;

class Motion {
 public:
  enum class Kind : std::uint8_t { constant, sine, steps, ramp, script };

  Motion() = default;  // constant:0

  [[nodiscard]] static MotionParseResult parse(std::string_view spec);

  // Shaft angle in turns `seconds` after the start, plus the manual offset.
  [[nodiscard]] double turns_at(double seconds) const noexcept;

  void set_offset(double turns) noexcept { offset_ = turns; }
  [[nodiscard]] double offset() const noexcept { return offset_; }

  [[nodiscard]] Kind kind() const noexcept { return kind_; }
  [[nodiscard]] const std::string& spec() const noexcept { return spec_; }

 private:
  [[nodiscard]] double curve_at(double seconds) const noexcept;

  Kind kind_ = Kind::constant;
  double a_ = 0.0;  // constant: turns/s; sine: amplitude; ramp: turns/s
  double b_ = 0.0;  // sine: period; ramp: max turns
  double c_ = 0.0;  // sine: centre offset
  std::vector<std::pair<double, double>> points_;  // steps / script: (seconds, turns)
  double offset_ = 0.0;
  std::string spec_ = "constant:0";
};

struct MotionParseResult {
  Motion motion;
  Error error;
  [[nodiscard]] bool ok() const noexcept { return error.ok(); }
};

}  // namespace cobridge::sim

template <>
struct std::is_error_code_enum<cobridge::sim::MotionError> : std::true_type {};
