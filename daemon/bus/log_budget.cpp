#include "bus/log_budget.hpp"

namespace cobridge::bus {

bool LogBudget::allow(canopen::TimePoint now) noexcept {
  if (used_ == 0 || now - window_start_ >= window_) {
    if (suppressed_ != 0) {
      // The summary of the old window is still owed: keep counting into it
      // until take_suppressed() reports it, so no line goes unaccounted.
      ++suppressed_;
      return false;
    }
    window_start_ = now;
    used_ = 0;
  }
  if (used_ < limit_) {
    ++used_;
    return true;
  }
  ++suppressed_;
  return false;
}

std::uint32_t LogBudget::take_suppressed(canopen::TimePoint now) noexcept {
  if (suppressed_ == 0 || now - window_start_ < window_) return 0;
  const std::uint32_t n = suppressed_;
  suppressed_ = 0;
  used_ = 0;
  return n;
}

canopen::TimePoint LogBudget::report_due() const noexcept {
  return suppressed_ == 0 ? canopen::kNever : window_start_ + window_;
}

}  // namespace cobridge::bus
