#include "bus/bus_clock.hpp"

namespace cobridge::bus {

namespace {

class SystemBusClock final : public BusClock {
 public:
  canopen::TimePoint now() const noexcept override { return canopen::Clock::now(); }
  WallTime wall() const noexcept override { return std::chrono::system_clock::now(); }
};

}  // namespace

const BusClock& system_bus_clock() noexcept {
  static const SystemBusClock clock;
  return clock;
}

}  // namespace cobridge::bus
