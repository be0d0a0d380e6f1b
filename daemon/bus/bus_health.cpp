#include "bus/bus_health.hpp"

namespace cobridge::bus {
namespace {

bool transition(const BusHealth& a, const BusHealth& b) noexcept {
  return a.open != b.open || a.controller.state != b.controller.state || a.controller.source != b.controller.source ||
         a.controller.driver != b.controller.driver;
}

bool counters_moved(const BusHealth& a, const BusHealth& b) noexcept {
  const auto& x = a.controller;
  const auto& y = b.controller;
  return x.counters_known != y.counters_known || x.tx_errors != y.tx_errors || x.rx_errors != y.rx_errors ||
         x.restarts != y.restarts || x.bus_errors != y.bus_errors || a.error_frames != b.error_frames;
}

}  // namespace

bool BusHealthGate::due(const BusHealth& health, canopen::TimePoint now) {
  const bool first = !told_;
  const bool at_once = first || transition(*told_, health);
  const bool moved = !first && counters_moved(*told_, health);
  if (!at_once && !moved) {
    held_ = false;  // back to what was told (a counter cannot, but a reopen's figures can)
    return false;
  }
  if (!at_once && now < told_at_ + period_) {
    held_ = true;
    return false;
  }
  told_ = health;
  told_at_ = now;
  held_ = false;
  return true;
}

}  // namespace cobridge::bus
