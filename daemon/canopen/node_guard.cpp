#include "canopen/node_guard.hpp"

#include <algorithm>

#include "canopen/cob_id.hpp"

namespace cobridge::canopen {

// ---------------------------------------------------------------------------
// NodeGuardMaster

bool NodeGuardMaster::configure(uint8_t node, Duration guard_time, uint8_t life_time_factor,
                                TimePoint now) noexcept {
  if (!cob::valid_node_id(node)) return false;
  NodeStatus& n = nodes_[node];
  n = NodeStatus{};
  if (guard_time <= Duration::zero() || life_time_factor == 0) return true;
  n.configured = true;
  n.guard_time = guard_time;
  n.life_time_factor = life_time_factor;
  n.next_request = now;
  n.last_valid = now;
  return true;
}

void NodeGuardMaster::remove(uint8_t node) noexcept {
  if (cob::valid_node_id(node)) nodes_[node] = NodeStatus{};
}

void NodeGuardMaster::forget_state(uint8_t node) noexcept {
  if (cob::valid_node_id(node)) nodes_[node].state_known = false;
}

NodeGuardMaster::NodeStatus NodeGuardMaster::status(uint8_t node) const noexcept {
  if (!cob::valid_node_id(node)) return NodeStatus{};
  return nodes_[node];
}

void NodeGuardMaster::emit(EventKind kind, uint8_t node, const NodeStatus& n, bool previous_known,
                           NmtState previous, TimePoint time) const noexcept {
  if (!callback_) return;
  Event e;
  e.kind = kind;
  e.node = node;
  e.state = n.state;
  e.previous = previous;
  e.previous_known = previous_known;
  e.time = time;
  callback_(e);
}

bool NodeGuardMaster::on_frame(const can::Frame& frame, TimePoint now) noexcept {
  const ErrorControlParse p = parse_error_control(frame);
  if (!p.ok()) return false;
  const uint8_t id = p.message.node;
  NodeStatus& n = nodes_[id];
  if (!n.configured) return false;

  const bool previous_known = n.state_known;
  const NmtState previous = n.state;

  if (p.message.is_boot_up) {
    // The node passed reset communication: its toggle restarts at 0. A boot-up
    // is not an answer to a request, so the life time keeps running.
    n.expected_toggle = false;
    n.state = NmtState::boot_up;
    n.state_known = true;
    emit(EventKind::boot_up, id, n, previous_known, previous, now);
    return true;
  }

  if (p.message.toggle != n.expected_toggle) {
    emit(EventKind::toggle_error, id, n, previous_known, previous, now);
    return true;
  }

  n.expected_toggle = !n.expected_toggle;
  n.last_valid = now;
  n.state = p.message.state;
  n.state_known = true;
  if (n.lost) {
    n.lost = false;
    emit(EventKind::recovered, id, n, previous_known, previous, now);
  }
  if (!previous_known || previous != n.state)
    emit(EventKind::state_changed, id, n, previous_known, previous, now);
  return true;
}

TimePoint NodeGuardMaster::process(TimePoint now, can::FrameSink& sink) noexcept {
  TimePoint next = kNever;
  for (uint8_t id = cob::kNodeIdMin; id <= cob::kNodeIdMax; ++id) {
    NodeStatus& n = nodes_[id];
    if (!n.configured) continue;

    const TimePoint life_deadline = n.last_valid + n.guard_time * n.life_time_factor;
    if (!n.lost && now >= life_deadline) {
      n.lost = true;
      emit(EventKind::lost, id, n, n.state_known, n.state, life_deadline);
    }

    if (now >= n.next_request) {
      if (sink.send(make_guard_request(id)))
        ++n.requests_sent;
      else
        ++n.send_failures;  // retried at the next period, not in a tight loop
      // Keep the polling grid; if the caller was late by more than a period,
      // skip the missed polls rather than sending a burst.
      n.next_request += n.guard_time;
      if (n.next_request <= now) n.next_request = now + n.guard_time;
    }

    next = std::min(next, n.next_request);
    if (!n.lost) next = std::min(next, life_deadline);
  }
  return next;
}

// ---------------------------------------------------------------------------
// GuardResponder

void GuardResponder::configure(Duration guard_time, uint8_t life_time_factor) noexcept {
  guard_time_ = guard_time;
  life_time_factor_ = life_time_factor;
}

void GuardResponder::reset_communication() noexcept {
  toggle_ = false;
  active_ = false;
  lost_ = false;
}

Duration GuardResponder::life_time() const noexcept {
  return guard_time_ * life_time_factor_;
}

can::Frame GuardResponder::reply(uint8_t node, NmtState state, TimePoint now) noexcept {
  const can::Frame f = make_guard_reply(node, state, toggle_);
  toggle_ = !toggle_;
  last_request_ = now;
  active_ = true;
  if (lost_) {
    lost_ = false;
    if (callback_) callback_(EventKind::life_guarding_resumed, now);
  }
  return f;
}

bool GuardResponder::on_frame(const can::Frame& frame, uint8_t node, NmtState state, TimePoint now,
                              can::Frame& out) noexcept {
  uint8_t requested = 0;
  if (!is_guard_request(frame, requested) || requested != node) return false;
  out = reply(node, state, now);
  return true;
}

TimePoint GuardResponder::process(TimePoint now) noexcept {
  if (!active_ || lost_ || life_time() <= Duration::zero()) return kNever;
  const TimePoint deadline = last_request_ + life_time();
  if (now < deadline) return deadline;
  lost_ = true;
  if (callback_) callback_(EventKind::life_guarding_lost, deadline);
  return kNever;
}

}  // namespace cobridge::canopen
