#include "canopen/heartbeat_consumer.hpp"

#include <algorithm>

#include "canopen/cob_id.hpp"

namespace cobridge::canopen {

bool HeartbeatConsumer::configure(uint8_t node, Duration consumer_time) noexcept {
  if (!cob::valid_node_id(node)) return false;
  NodeStatus& n = nodes_[node];
  if (consumer_time <= Duration::zero()) {
    n = NodeStatus{};
    return true;
  }
  if (!n.configured) n = NodeStatus{};
  n.configured = true;
  n.consumer_time = consumer_time;
  return true;
}

void HeartbeatConsumer::restart_period(uint8_t node, TimePoint at) noexcept {
  if (!cob::valid_node_id(node)) return;
  NodeStatus& n = nodes_[node];
  if (n.configured && n.armed && !n.timed_out && at > n.last_seen) n.last_seen = at;
}

void HeartbeatConsumer::remove(uint8_t node) noexcept {
  if (cob::valid_node_id(node)) nodes_[node] = NodeStatus{};
}

void HeartbeatConsumer::forget_state(uint8_t node) noexcept {
  if (cob::valid_node_id(node)) nodes_[node].state_known = false;
}

HeartbeatConsumer::NodeStatus HeartbeatConsumer::status(uint8_t node) const noexcept {
  if (!cob::valid_node_id(node)) return NodeStatus{};
  return nodes_[node];
}

void HeartbeatConsumer::emit(EventKind kind, uint8_t node, NmtState state, bool previous_known,
                             NmtState previous, TimePoint time) const noexcept {
  if (!callback_) return;
  Event e;
  e.kind = kind;
  e.node = node;
  e.state = state;
  e.previous = previous;
  e.previous_known = previous_known;
  e.time = time;
  callback_(e);
}

bool HeartbeatConsumer::on_frame(const can::Frame& frame, TimePoint now) noexcept {
  const ErrorControlParse p = parse_error_control(frame);
  if (!p.ok()) return false;
  NodeStatus& n = nodes_[p.message.node];
  if (!n.configured) return false;

  const bool previous_known = n.state_known;
  const NmtState previous = n.state;
  n.last_seen = now;
  n.state = p.message.state;
  n.state_known = true;

  if (p.message.is_boot_up) {
    n.armed = false;
    n.timed_out = false;
    emit(EventKind::boot_up, p.message.node, n.state, previous_known, previous, now);
    return true;
  }

  n.armed = true;
  if (n.timed_out) {
    n.timed_out = false;
    emit(EventKind::recovered, p.message.node, n.state, previous_known, previous, now);
  }
  if (!previous_known || previous != n.state)
    emit(EventKind::state_changed, p.message.node, n.state, previous_known, previous, now);
  return true;
}

TimePoint HeartbeatConsumer::process(TimePoint now) noexcept {
  TimePoint next = kNever;
  for (uint8_t id = cob::kNodeIdMin; id <= cob::kNodeIdMax; ++id) {
    NodeStatus& n = nodes_[id];
    if (!n.configured || !n.armed || n.timed_out) continue;
    const TimePoint deadline = n.last_seen + n.consumer_time;
    if (now >= deadline) {
      n.timed_out = true;
      emit(EventKind::timeout, id, n.state, true, n.state, deadline);
    } else {
      next = std::min(next, deadline);
    }
  }
  return next;
}

}  // namespace cobridge::canopen
