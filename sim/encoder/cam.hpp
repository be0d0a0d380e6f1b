// CamBank: the electronic CAMs of one position channel (CiA 406 0x6300..0x633x).
//
// Each CAM is active while the output position lies in [low, high] (J§1.4.5,
// E§5.6); high < low is allowed and means the window wraps (active when
// pos >= low || pos <= high, J§1.4.5). Hysteresis is "added in the
// direction of motion" (J§1.4.5, E§5.6), read literally:
// moving up the switch points are limit + hyst, moving down limit - hyst, at
// standstill the state holds. Implemented as one Schmitt trigger per edge,
// which gives exactly those switch points and holds inside the band; the very
// first evaluation (and the first after a limit change) uses the plain window.
// Polarity inverts the reported bit; a disabled CAM reads 0 whatever the
// polarity (0x6301 "permanently 0").
//
// Rotary: 4 CAMs per channel (J§1.2.3); multiturn: 4 (E§4.2); ifm: 8 (F§7.5).
// `evaluate` returns the 0x6300 state byte and the mask of CAMs whose reported
// bit changed, which feed EMCY 0x9080 (J: b3-4 channel, b5-6 changed mask,
// b7 state; E: byte 4 changed mask, byte 7 state).
// Thread: owned by the simulator's bus thread; noexcept, no allocation.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace cobridge::sim {

struct CamLimits {
  std::int64_t low = 0;         // 0x631x
  std::int64_t high = 0;        // 0x632x
  std::int64_t hysteresis = 0;  // 0x633x (magnitude is used)
};

struct CamUpdate {
  std::uint8_t state = 0;    // 0x6300/ch
  std::uint8_t changed = 0;  // bits whose state changed since the last evaluation
  [[nodiscard]] bool any_change() const noexcept { return changed != 0; }
};

class CamBank {
 public:
  static constexpr std::size_t kMaxCams = 8;

  explicit CamBank(std::size_t cam_count) noexcept;

  [[nodiscard]] std::size_t size() const noexcept { return count_; }

  void set_limits(std::size_t cam, CamLimits limits) noexcept;
  void set_low(std::size_t cam, std::int64_t low) noexcept;
  void set_high(std::size_t cam, std::int64_t high) noexcept;
  void set_hysteresis(std::size_t cam, std::int64_t hysteresis) noexcept;
  [[nodiscard]] const CamLimits& limits(std::size_t cam) const noexcept { return limits_[cam]; }

  void set_enable_mask(std::uint8_t mask) noexcept { enable_ = mask; }      // 0x6301/ch
  void set_polarity_mask(std::uint8_t mask) noexcept { polarity_ = mask; }  // 0x6302/ch
  [[nodiscard]] std::uint8_t enable_mask() const noexcept { return enable_; }
  [[nodiscard]] std::uint8_t polarity_mask() const noexcept { return polarity_; }

  // One measuring cycle with the output position (after scaling and preset).
  CamUpdate evaluate(std::int64_t position) noexcept;

  [[nodiscard]] std::uint8_t state() const noexcept { return state_; }
  // Enabled CAMs whose window contains the position, before polarity (used by
  // the multiturn lot-size counter, E§4.3, E§5.8).
  [[nodiscard]] std::uint8_t active_mask() const noexcept;

  // Back to power-on: state 0, no memory of the previous position.
  void reset() noexcept;

 private:
  struct Trigger {
    bool above_low = false;   // passed the low edge
    bool below_high = false;  // not yet past the high edge
    bool primed = false;      // false: next evaluation uses the plain window
  };
  [[nodiscard]] std::uint8_t valid_bits() const noexcept {
    return static_cast<std::uint8_t>((1U << count_) - 1U);
  }

  std::size_t count_;
  std::array<CamLimits, kMaxCams> limits_{};
  std::array<Trigger, kMaxCams> triggers_{};
  std::uint8_t enable_ = 0;
  std::uint8_t polarity_ = 0;
  std::uint8_t state_ = 0;
};

}  // namespace cobridge::sim
