// BusClock: the two clocks a bus's control thread reads, handed in so that
// the controller's decisions run in unit tests on a fake clock (the
// protocol components below it already take `now` as an argument).
//   now():  steady time, for every deadline and timeout;
//   wall(): realtime, for what status, timelines and captures show.
// Thread: the system clock may be read from any thread; a test's clock
// belongs to the test's one thread.
#pragma once

#include "bus/device_status.hpp"
#include "canopen/clock.hpp"

namespace cobridge::bus {

class BusClock {
 public:
  virtual ~BusClock() = default;
  [[nodiscard]] virtual canopen::TimePoint now() const noexcept = 0;
  [[nodiscard]] virtual WallTime wall() const noexcept = 0;
};

// std::chrono::steady_clock and system_clock.
[[nodiscard]] const BusClock& system_bus_clock() noexcept;

}  // namespace cobridge::bus
