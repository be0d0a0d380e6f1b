#include "app/simulated_bus.hpp"

#include "canopen/cob_id.hpp"

#include <algorithm>

namespace cobridge::sim {

class SimulatedBus::DeviceSink final : public can::FrameSink {
 public:
  DeviceSink(SimulatedBus& bus, std::size_t index) : bus_(bus), index_(index) {}
  [[nodiscard]] bool send(const can::Frame& frame) noexcept override { return bus_.device_send(index_, frame); }

 private:
  SimulatedBus& bus_;
  std::size_t index_;
};

namespace {
can::SocketCanConfig channel_config(const std::string& iface) {
  can::SocketCanConfig c;
  c.interface = iface;
  // A device's frame waits at most this long for room in the kernel queue;
  // a real controller would keep retrying, a simulator must keep its loop.
  c.tx_timeout = std::chrono::milliseconds(2);
  c.receive_buffer_bytes = 1 << 20;
  // A device's transceiver is on the wire the moment the link is; the
  // simulator's socket must not lag behind it by a long reopen backoff.
  c.reopen_backoff_max = std::chrono::milliseconds(50);
  return c;
}
}  // namespace

SimulatedBus::SimulatedBus(std::string iface) : iface_(std::move(iface)), channel_(channel_config(iface_)) {}

SimulatedBus::~SimulatedBus() = default;

Error SimulatedBus::open() { return channel_.open(); }

can::FrameSink& SimulatedBus::sink_for(std::size_t device_index) {
  while (sinks_.size() <= device_index) sinks_.push_back(std::make_unique<DeviceSink>(*this, sinks_.size()));
  return *sinks_[device_index];
}

void SimulatedBus::add_device(std::unique_ptr<SimDevice> device) {
  devices_.push_back(std::move(device));
  silent_.push_back(0);
}

void SimulatedBus::set_silent(std::size_t i, bool silent) {
  devices_[i]->set_silent(silent);
  silent_[i] = silent ? 1 : 0;
}

bool SimulatedBus::merges_with_sent_answer(const can::Frame& frame) noexcept {
  if (!in_instant_ || frame.id != canopen::cob::kLssSlaveToMaster || frame.is_extended()) return false;
  if (lss_answered_ && frame.len == lss_answer_.len && frame.data == lss_answer_.data) {
    ++stats_.lss_merged;
    return true;
  }
  return false;
}

bool SimulatedBus::device_send(std::size_t index, const can::Frame& frame) noexcept {
  // Sent: on the wire it is the frame already there, seen once by everybody.
  last_send_merged_ = merges_with_sent_answer(frame);
  if (last_send_merged_) return true;
  // Identifier 0 back to back wins every arbitration: nobody else gets on.
  if (traffic_.flooding(now_) || !channel_.send(frame)) {
    ++stats_.device_refused;
    return false;
  }
  ++stats_.device_frames;
  if (in_instant_ && frame.id == canopen::cob::kLssSlaveToMaster && !lss_answered_) {
    lss_answer_ = frame;
    lss_answered_ = true;
  }
  queue_local(frame, static_cast<std::uint32_t>(index));
  return true;
}

void SimulatedBus::queue_local(const can::Frame& frame, std::uint32_t source) noexcept {
  if (devices_.size() < 2 && source != kNoDevice) return;  // nobody else to tell
  if (tail_ - head_ >= kLocalRing) {
    ++stats_.local_overflow;
    return;
  }
  ring_[tail_ % kLocalRing] = Local{frame, source};
  ++tail_;
}

void SimulatedBus::deliver_local(canopen::TimePoint now) noexcept {
  if (delivering_) return;  // a device sent from inside on_frame: the loop below picks it up
  delivering_ = true;
  while (head_ != tail_) {
    const Local l = ring_[head_ % kLocalRing];
    ++head_;
    for (std::size_t i = 0; i < devices_.size(); ++i) {
      if (i == l.source) continue;
      devices_[i]->on_frame(l.frame, now);
      ++stats_.local_deliveries;
    }
  }
  delivering_ = false;
}

void SimulatedBus::receive(canopen::TimePoint now) noexcept {
  now_ = now;
  // At most a few batches per loop turn, so a flood from outside cannot
  // starve the devices' timers.
  for (int batch = 0; batch < 8; ++batch) {
    const std::size_t n = channel_.receive(rx_);
    for (std::size_t k = 0; k < n; ++k) {
      // One request, one instant: the answers it causes go out together.
      in_instant_ = true;
      lss_answered_ = false;
      for (auto& d : devices_) d->on_frame(rx_[k], now);
      in_instant_ = false;
      deliver_local(now);
    }
    stats_.received += n;
    if (n < rx_.size()) break;
  }
  (void)channel_.take_events();  // error frames from elsewhere: the devices model their own controller
}

canopen::TimePoint SimulatedBus::process(canopen::TimePoint now) noexcept {
  now_ = now;
  canopen::TimePoint next = channel_.process(now);
  for (auto& d : devices_) {
    next = std::min(next, d->process(now));
    deliver_local(now);
  }
  if (traffic_.active(now)) {
    std::array<can::Frame, kBurst> burst{};
    const std::size_t n = traffic_.burst(now, burst);
    for (std::size_t k = 0; k < n; ++k) {
      if (!channel_.send(burst[k])) break;
      ++stats_.injected;
      queue_local(burst[k], kNoDevice);
    }
    deliver_local(now);
  }
  return std::min(next, traffic_.process(now));
}

bool SimulatedBus::send_error_frame(BusErrorKind kind, canopen::TimePoint now) noexcept {
  now_ = now;
  const can::Frame f = make_error_frame(kind);
  const bool sent = channel_.send(f);
  if (sent) ++stats_.injected;
  // The simulated controllers saw the same bus state, whether or not the
  // frame made it to the wire.
  queue_local(f, kNoDevice);
  deliver_local(now);
  return sent;
}

}  // namespace cobridge::sim
