// WorkArea: the work-area state register 0x6400 of one channel and its
// change detection for EMCY 0x9090.
//
// Bits (all families): bit 2 "range underflow" = pos < low (0x6401); bit 1
// "range overflow" = pos > high (0x6402); bit 0 "out of range" per family:
//   rotary (J§1.4.6.1):    pos <= preset or pos >= sensor length (inclusive, as printed)
//   multiturn (E§5.7.1):   pos <= min or pos >= max of 0x650A/2..3 (inclusive, as printed)
//   ifm (F§7.5 0x6400):    pos outside 0x650A/2..3 (exclusive)
// Errata applied: J prints bit 1 as "pos < high" (inverted),
// F's table swaps 0x6401/0x6402 and the directions (F§7.5 0x6400); both use
// the object descriptions: bit 1 = pos > high, bit 2 = pos < low.
// The register starts at 0 (OD default), so the first evaluation reports a
// change when the position starts outside the area.
// EMCY 0x9090 state byte: J and E (default) the 0x6400 value; E optionally the
// enumeration 0 valid / 1 underflow / 2 overflow (E§9.1 text, E§9.1).
// Thread: owned by the simulator's bus thread; noexcept, no allocation.
#pragma once

#include <cstdint>

namespace cobridge::sim {

enum class WorkAreaRule : std::uint8_t { rotary = 0, multiturn = 1, ifm = 2 };

inline constexpr std::uint8_t kWorkAreaOutOfRange = 0x01;
inline constexpr std::uint8_t kWorkAreaOverflow = 0x02;
inline constexpr std::uint8_t kWorkAreaUnderflow = 0x04;

struct WorkAreaLimits {
  std::int64_t low = 0;   // 0x6401/ch
  std::int64_t high = 0;  // 0x6402/ch
  // Bit-0 bounds. Rotary: range_min = preset (0x6010/ch), range_max = sensor
  // length (total measuring range 0x6002). Multiturn, ifm: 0x650A/2 and /3.
  std::int64_t range_min = 0;
  std::int64_t range_max = 0;
};

// The 0x6400 value for a position.
[[nodiscard]] std::uint8_t work_area_state(WorkAreaRule rule, const WorkAreaLimits& limits,
                                           std::int64_t position) noexcept;

enum class WorkAreaEmcyCoding : std::uint8_t {
  state_bits,   // byte 7 = the 0x6400 value (J; E default, "coded according to 0x6400")
  enumeration,  // E§9.1: 0 valid, 1 underflow, 2 overflow (bit 0 alone reads 0)
};
[[nodiscard]] std::uint8_t work_area_emcy_state(std::uint8_t state, WorkAreaEmcyCoding coding) noexcept;

struct WorkAreaUpdate {
  std::uint8_t state = 0;
  bool changed = false;
};

class WorkArea {
 public:
  explicit WorkArea(WorkAreaRule rule, WorkAreaLimits limits = {}) noexcept : rule_(rule), limits_(limits) {}

  [[nodiscard]] WorkAreaLimits& limits() noexcept { return limits_; }
  [[nodiscard]] const WorkAreaLimits& limits() const noexcept { return limits_; }

  WorkAreaUpdate evaluate(std::int64_t position) noexcept;
  [[nodiscard]] std::uint8_t state() const noexcept { return state_; }
  void reset() noexcept { state_ = 0; }

 private:
  WorkAreaRule rule_;
  WorkAreaLimits limits_;
  std::uint8_t state_ = 0;
};

}  // namespace cobridge::sim
