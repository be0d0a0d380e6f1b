#include "encoder/work_area.hpp"

namespace cobridge::sim {

std::uint8_t work_area_state(WorkAreaRule rule, const WorkAreaLimits& l, std::int64_t pos) noexcept {
  std::uint8_t state = 0;
  if (pos < l.low) state |= kWorkAreaUnderflow;
  if (pos > l.high) state |= kWorkAreaOverflow;
  bool out = false;
  switch (rule) {
    case WorkAreaRule::rotary:     // J§1.4.6.1, inclusive as printed
    case WorkAreaRule::multiturn:  // E§5.7.1, inclusive as printed
      out = pos <= l.range_min || pos >= l.range_max;
      break;
    case WorkAreaRule::ifm:  // F§7.5: "position out of range (refer to 0x650A)"
      out = pos < l.range_min || pos > l.range_max;
      break;
  }
  if (out) state |= kWorkAreaOutOfRange;
  return state;
}

std::uint8_t work_area_emcy_state(std::uint8_t state, WorkAreaEmcyCoding coding) noexcept {
  if (coding == WorkAreaEmcyCoding::state_bits) return state;
  if ((state & kWorkAreaUnderflow) != 0) return 1;
  if ((state & kWorkAreaOverflow) != 0) return 2;
  return 0;
}

WorkAreaUpdate WorkArea::evaluate(std::int64_t position) noexcept {
  const std::uint8_t s = work_area_state(rule_, limits_, position);
  WorkAreaUpdate u{s, s != state_};
  state_ = s;
  return u;
}

}  // namespace cobridge::sim
