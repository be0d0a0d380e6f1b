#include "can/virtual_bus.hpp"

namespace cobridge::can {

bool VirtualBus::Port::send(const Frame& frame) noexcept {
  if (send_blocked_ || !open_) {
    ++stats_.tx_dropped;
    return false;
  }
  // The interface is noexcept; a test that runs out of memory may terminate.
  bus_->broadcast(*this, frame);
  ++stats_.tx_frames;
  return true;
}

std::size_t VirtualBus::Port::receive(std::span<Frame> out) noexcept {
  std::size_t n = 0;
  while (open_ && n < out.size() && receive(out[n])) ++n;
  stats_.rx_frames += n;
  return n;
}

// The interface is noexcept; a test that runs out of memory may terminate.
std::span<const BusEvent> VirtualBus::Port::take_events() noexcept {
  taken_.clear();
  taken_.swap(events_);
  return taken_;
}

void VirtualBus::Port::add_event(const BusEvent& event) { events_.push_back(event); }

void VirtualBus::Port::set_open(bool open) {
  if (open == open_) return;
  open_ = open;
  BusEvent e;
  e.kind = open ? BusEventKind::InterfaceReopened : BusEventKind::InterfaceDown;
  add_event(e);
  if (open) ++stats_.reopens;
}

bool VirtualBus::Port::receive(Frame& out) noexcept {
  if (queue_.empty()) return false;
  out = queue_.front();
  queue_.pop_front();
  return true;
}

void VirtualBus::Port::deliver(const Frame& frame) {
  if (!open_) return;  // interface down: the frame never reaches the socket
  if (queue_.size() >= capacity_) {
    ++rx_dropped_;
    ++stats_.rx_overflow_drops;  // as a socket's SO_RXQ_OVFL counts them
    return;
  }
  queue_.push_back(frame);
}

VirtualBus::Port& VirtualBus::attach(std::size_t capacity) {
  ports_.push_back(std::unique_ptr<Port>(new Port(*this, capacity)));
  return *ports_.back();
}

void VirtualBus::broadcast(const Port& from, const Frame& sent) {
  Frame frame = sent;
  if (stamp_) frame.timestamp_ns = stamp_();
  log_.push_back(frame);
  for (const auto& p : ports_)
    if (p.get() != &from) p->deliver(frame);
}

}  // namespace cobridge::can
