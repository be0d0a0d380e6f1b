#include "encoder/cam.hpp"

#include <algorithm>
#include <cstdlib>

namespace cobridge::sim {

CamBank::CamBank(std::size_t cam_count) noexcept : count_(std::clamp<std::size_t>(cam_count, 1, kMaxCams)) {}

void CamBank::set_limits(std::size_t cam, CamLimits limits) noexcept {
  if (cam >= count_) return;
  limits_[cam] = limits;
  triggers_[cam].primed = false;
}

void CamBank::set_low(std::size_t cam, std::int64_t low) noexcept {
  if (cam >= count_) return;
  set_limits(cam, {low, limits_[cam].high, limits_[cam].hysteresis});
}

void CamBank::set_high(std::size_t cam, std::int64_t high) noexcept {
  if (cam >= count_) return;
  set_limits(cam, {limits_[cam].low, high, limits_[cam].hysteresis});
}

void CamBank::set_hysteresis(std::size_t cam, std::int64_t hysteresis) noexcept {
  if (cam >= count_) return;
  // Changing only the band keeps the current state: the position has not moved.
  limits_[cam].hysteresis = hysteresis;
}

void CamBank::reset() noexcept {
  for (auto& t : triggers_) t = Trigger{};
  state_ = 0;
}

std::uint8_t CamBank::active_mask() const noexcept {
  std::uint8_t mask = 0;
  for (std::size_t i = 0; i < count_; ++i) {
    const auto& l = limits_[i];
    const auto& t = triggers_[i];
    const bool active = l.high < l.low ? (t.above_low || t.below_high) : (t.above_low && t.below_high);
    if (t.primed && active) mask = static_cast<std::uint8_t>(mask | (1U << i));
  }
  return static_cast<std::uint8_t>(mask & enable_);
}

CamUpdate CamBank::evaluate(std::int64_t position) noexcept {
  for (std::size_t i = 0; i < count_; ++i) {
    const auto& l = limits_[i];
    auto& t = triggers_[i];
    if (!t.primed) {
      t.above_low = position >= l.low;
      t.below_high = position <= l.high;
      t.primed = true;
      continue;
    }
    const std::int64_t h = std::llabs(l.hysteresis);
    // Low edge: switches on moving up at low + h, off moving down below low - h.
    if (position >= l.low + h) {
      t.above_low = true;
    } else if (position < l.low - h) {
      t.above_low = false;
    }
    // High edge: switches off moving up beyond high + h, on moving down at high - h.
    if (position > l.high + h) {
      t.below_high = false;
    } else if (position <= l.high - h) {
      t.below_high = true;
    }
  }
  const std::uint8_t active = active_mask();
  const auto state = static_cast<std::uint8_t>((active ^ polarity_) & enable_ & valid_bits());
  CamUpdate u;
  u.changed = static_cast<std::uint8_t>(state ^ state_);
  u.state = state;
  state_ = state;
  return u;
}

}  // namespace cobridge::sim
