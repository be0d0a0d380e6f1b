#include "can/virtual_bus.hpp"

namespace cobridge::can {

bool VirtualBus::Port::send(const Frame& frame) noexcept {
  if (send_blocked_) {
    ++tx_refused_;
    return false;
  }
  // The interface is noexcept; a test that runs out of memory may terminate.
  bus_->broadcast(*this, frame);
  return true;
}

bool VirtualBus::Port::receive(Frame& out) noexcept {
  if (queue_.empty()) return false;
  out = queue_.front();
  queue_.pop_front();
  return true;
}

void VirtualBus::Port::deliver(const Frame& frame) {
  if (queue_.size() >= capacity_) {
    ++rx_dropped_;
    return;
  }
  queue_.push_back(frame);
}

VirtualBus::Port& VirtualBus::attach(std::size_t capacity) {
  ports_.push_back(std::unique_ptr<Port>(new Port(*this, capacity)));
  return *ports_.back();
}

void VirtualBus::broadcast(const Port& from, const Frame& frame) {
  log_.push_back(frame);
  for (const auto& p : ports_)
    if (p.get() != &from) p->deliver(frame);
}

}  // namespace cobridge::can
