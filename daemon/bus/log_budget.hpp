// LogBudget: how many lines one source (a device's EMCY, say) may log per
// window. A storm of identical news must not bury the journal (4 600 lines in
// 3 s were seen from one device), yet the operator must learn how much was
// left out: the lines over budget are counted, and the count is handed back
// once the window has passed, for one summary line.
//
// Thread: owned by one thread (the bus manager's control thread); no clock
// reads, `now` is passed in.
#pragma once

#include <chrono>
#include <cstdint>

#include "canopen/clock.hpp"

namespace cobridge::bus {

class LogBudget {
 public:
  explicit LogBudget(std::uint32_t lines_per_window = 5,
                     canopen::Duration window = std::chrono::seconds(10)) noexcept
      : limit_(lines_per_window), window_(window) {}

  // True when this line may be logged; false = counted as suppressed.
  [[nodiscard]] bool allow(canopen::TimePoint now) noexcept;
  // Lines suppressed in a window that has ended (0 otherwise); resets the count.
  [[nodiscard]] std::uint32_t take_suppressed(canopen::TimePoint now) noexcept;
  // When take_suppressed() will have something to report (kNever: nothing pending).
  [[nodiscard]] canopen::TimePoint report_due() const noexcept;

 private:
  std::uint32_t limit_;
  canopen::Duration window_;
  canopen::TimePoint window_start_{};
  std::uint32_t used_ = 0;
  std::uint32_t suppressed_ = 0;
};

}  // namespace cobridge::bus
