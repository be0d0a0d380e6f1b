#include "device/tpdo.hpp"

#include <algorithm>
#include <chrono>

namespace cobridge::sim {

void Tpdo::configure(const TpdoParams& params, TimePoint now) noexcept {
  params_ = params;
  pending_ = false;
  changed_ = false;
  sample_ = false;
  sync_count_ = 0;
  next_event_ = canopen::kNever;
  if (active() && is_async_type() && params_.event_ms > 0)
    next_event_ = now + std::chrono::milliseconds(params_.event_ms);
}

void Tpdo::set_running(bool running, TimePoint now) noexcept {
  if (running == running_) return;
  running_ = running;
  have_sent_ = false;
  configure(params_, now);
}

bool Tpdo::active() const noexcept {
  if (!running_ || !valid()) return false;
  if (params_.type == 0 && policy_.type0_off) return false;
  return true;
}

Duration Tpdo::inhibit() const noexcept { return std::chrono::microseconds(100) * params_.inhibit_100us; }

TimePoint Tpdo::inhibit_end() const noexcept { return have_sent_ ? last_sent_ + inhibit() : TimePoint::min(); }

void Tpdo::request(TimePoint now) noexcept {
  (void)now;
  pending_ = true;
}

void Tpdo::on_sync(TimePoint now) noexcept {
  if (!active()) return;
  if (params_.type == 0) {
    if (changed_) request(now);
    return;
  }
  if (params_.type == 252) {
    sample_ = true;
    return;
  }
  if (!is_sync_type()) return;
  if (++sync_count_ < params_.type) return;
  sync_count_ = 0;
  // Synchronous data is only worth sending at the SYNC itself.
  if (now >= inhibit_end()) request(now);
}

void Tpdo::on_measure(TimePoint now, bool changed) noexcept {
  if (!active()) return;
  if (changed) changed_ = true;
  if (!is_async_type()) return;
  if (policy_.type255_every_cycle && params_.type == 255) {
    request(now);
  } else if (policy_.on_change && changed) {
    request(now);
  }
}

bool Tpdo::on_rtr(TimePoint now) noexcept {
  if (!policy_.rtr || !active() || (params_.cob_id & kNoRtr) != 0) return false;
  request(now);
  return true;
}

bool Tpdo::sample_pending() noexcept {
  const bool s = sample_;
  sample_ = false;
  return s;
}

bool Tpdo::due(TimePoint now) const noexcept {
  if (!active()) return false;
  const bool wanted = pending_ || now >= next_event_;
  return wanted && now >= inhibit_end();
}

void Tpdo::sent(TimePoint now) noexcept {
  have_sent_ = true;
  last_sent_ = now;
  pending_ = false;
  changed_ = false;
  if (is_async_type() && params_.event_ms > 0) {
    // Keep the event grid when on time, so a 1 ms timer gives exactly 1000
    // frames a second; restart from now when the frame was late or was a
    // change-triggered one (CiA 301: the timer restarts on transmission).
    const auto period = std::chrono::milliseconds(params_.event_ms);
    if (now >= next_event_ && now < next_event_ + period)
      next_event_ += period;
    else
      next_event_ = now + period;
  }
}

TimePoint Tpdo::next_deadline() const noexcept {
  if (!active()) return canopen::kNever;
  TimePoint t = pending_ ? TimePoint::min() : next_event_;
  if (t == canopen::kNever) return t;
  return std::max(t, inhibit_end());
}

}  // namespace cobridge::sim
