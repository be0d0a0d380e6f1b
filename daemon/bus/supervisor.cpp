#include "bus/supervisor.hpp"

#include "canopen/cob_id.hpp"
#include "device/emcy_meaning.hpp"

#include <algorithm>

namespace cobridge::bus {

using canopen::TimePoint;

namespace {

std::string milliseconds_text(canopen::Duration d) {
  return std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(d).count()) + " ms";
}

}  // namespace

std::chrono::milliseconds consumer_time_for(std::chrono::milliseconds producer) noexcept {
  if (producer <= std::chrono::milliseconds::zero()) return std::chrono::milliseconds::zero();
  return producer + producer / 2 + kConsumerMargin;
}

Supervisor::Supervisor() {
  heartbeat_.set_callback([this](const canopen::HeartbeatConsumer::Event& e) { on_heartbeat_event(e); });
  guard_.set_callback([this](const canopen::NodeGuardMaster::Event& e) { on_guard_event(e); });
  changes_.reserve(32);
}

void Supervisor::watch(std::uint8_t node, const families::Family* family, const Supervision& supervision,
                       TimePoint now) {
  if (!canopen::cob::valid_node_id(node)) return;
  Node& n = nodes_[node];
  heartbeat_.remove(node);
  guard_.remove(node);
  n.known = true;
  n.watched = true;
  n.family = family;
  n.supervision = supervision;
  n.heard = false;
  n.online = false;  // online again with its first heartbeat / guarding reply
  n.first_deadline = canopen::kNever;
  // watch() follows the NMT start: anything else reported later is a change.
  n.nmt = canopen::NmtState::operational;
  switch (supervision.mode) {
    case Supervision::Mode::heartbeat: {
      const auto consumer = consumer_time_for(supervision.producer_time);
      heartbeat_.configure(node, consumer);
      // The consumer arms on the first heartbeat only; a device that never
      // sends one after its start must be reported all the same.
      n.first_deadline = now + consumer;
      break;
    }
    case Supervision::Mode::guarding:
      // The master counts the life time from now, so silence is covered.
      guard_.configure(node, supervision.guard_time, supervision.life_time_factor, now);
      break;
    case Supervision::Mode::none:
      break;
  }
}

bool Supervisor::follow_producer_time(std::uint8_t node, std::chrono::milliseconds producer_time) noexcept {
  if (!canopen::cob::valid_node_id(node)) return false;
  Node& n = nodes_[node];
  if (!n.watched || n.supervision.mode != Supervision::Mode::heartbeat) return false;
  if (producer_time <= std::chrono::milliseconds::zero()) {
    heartbeat_.remove(node);
    n.supervision.mode = Supervision::Mode::none;
    n.first_deadline = canopen::kNever;
    return true;
  }
  n.supervision.producer_time = producer_time;
  // configure() keeps an armed consumer's last heartbeat; its deadline is
  // that heartbeat plus the new consumer time.
  heartbeat_.configure(node, consumer_time_for(producer_time));
  return true;
}

void Supervisor::producer_time_written(std::uint8_t node, canopen::TimePoint at) noexcept {
  if (!canopen::cob::valid_node_id(node)) return;
  heartbeat_.restart_period(node, at);
  // Not heard since its start: the first heartbeat is due a consumer time
  // after the write, not after the start.
  Node& n = nodes_[node];
  if (n.watched && n.first_deadline != canopen::kNever && n.supervision.mode == Supervision::Mode::heartbeat)
    n.first_deadline = std::max(n.first_deadline, at + consumer_time_for(n.supervision.producer_time));
}

void Supervisor::forget_nmt(std::uint8_t node) noexcept {
  if (!canopen::cob::valid_node_id(node)) return;
  nodes_[node].nmt = canopen::NmtState::boot_up;
  // The consumers report changes of their own record: forgotten there too,
  // or the same state heard again would be no change at all.
  heartbeat_.forget_state(node);
  guard_.forget_state(node);
}

void Supervisor::listen(std::uint8_t node, const families::Family* family) {
  if (!canopen::cob::valid_node_id(node)) return;
  Node& n = nodes_[node];
  heartbeat_.remove(node);
  guard_.remove(node);
  n.known = true;
  n.watched = false;
  n.family = family;
  n.supervision = Supervision{};
  n.online = false;
  n.heard = false;
  n.first_deadline = canopen::kNever;
}

void Supervisor::unwatch(std::uint8_t node) noexcept {
  if (!canopen::cob::valid_node_id(node)) return;
  heartbeat_.remove(node);
  guard_.remove(node);
  nodes_[node] = Node{};
}

bool Supervisor::watching(std::uint8_t node) const noexcept {
  return canopen::cob::valid_node_id(node) && nodes_[node].watched;
}

bool Supervisor::online(std::uint8_t node) const noexcept {
  return canopen::cob::valid_node_id(node) && nodes_[node].online;
}

canopen::NmtState Supervisor::nmt(std::uint8_t node) const noexcept {
  return canopen::cob::valid_node_id(node) ? nodes_[node].nmt : canopen::NmtState::boot_up;
}

void Supervisor::push(Change change) { changes_.push_back(std::move(change)); }

void Supervisor::set_online(std::uint8_t node, TimePoint at) {
  Node& n = nodes_[node];
  n.heard = true;
  n.first_deadline = canopen::kNever;
  if (n.online) return;
  n.online = true;
  Change c;
  c.kind = ChangeKind::online;
  c.node = node;
  c.at = at;
  c.nmt = n.nmt;
  if (n.silent_since != canopen::kNever && at >= n.silent_since) {
    c.reason = "heard again after " + milliseconds_text(at - n.silent_since) + " of silence";
  }
  n.silent_since = canopen::kNever;
  push(std::move(c));
}

void Supervisor::set_offline(std::uint8_t node, TimePoint at, std::string reason) {
  Node& n = nodes_[node];
  n.first_deadline = canopen::kNever;
  // A device that was never online (first heartbeat missing) is reported as
  // well: operators need the reason either way.
  if (!n.online && n.heard) return;
  n.online = false;
  n.heard = true;  // report the loss once
  Change c;
  c.kind = ChangeKind::offline;
  c.node = node;
  c.at = at;
  c.nmt = n.nmt;
  c.reason = std::move(reason);
  push(std::move(c));
}

void Supervisor::on_alive(std::uint8_t node, canopen::NmtState state, TimePoint at) {
  Node& n = nodes_[node];
  const bool changed = n.nmt != state;
  n.nmt = state;
  set_online(node, at);
  // Also after a loss: a device that comes back pre-operational has reset
  // unseen (its boot-up lost while the bus was away) and needs configuring.
  if (changed) {
    Change c;
    c.kind = ChangeKind::nmt_state;
    c.node = node;
    c.at = at;
    c.nmt = state;
    c.frame_ns = n.last_frame_ns;
    push(std::move(c));
  }
}

void Supervisor::on_heartbeat_event(const canopen::HeartbeatConsumer::Event& e) {
  using K = canopen::HeartbeatConsumer::EventKind;
  switch (e.kind) {
    case K::boot_up:
      break;  // handled in on_frame for every known node
    case K::state_changed:
    case K::recovered:
      on_alive(e.node, e.state, e.time);
      break;
    case K::timeout:
      set_offline(e.node, e.time, heartbeat_loss_text(e.node, e.time));
      break;
  }
}

std::string Supervisor::heartbeat_loss_text(std::uint8_t node, TimePoint detected) {
  const canopen::HeartbeatConsumer::NodeStatus st = heartbeat_.status(node);
  Node& n = nodes_[node];
  n.silent_since = st.last_seen;
  return "heartbeat lost: none for " + milliseconds_text(detected - st.last_seen) + " (consumer time " +
         milliseconds_text(st.consumer_time) + ", producer time " + milliseconds_text(n.supervision.producer_time) +
         ")";
}

void Supervisor::on_guard_event(const canopen::NodeGuardMaster::Event& e) {
  using K = canopen::NodeGuardMaster::EventKind;
  switch (e.kind) {
    case K::boot_up:
    case K::toggle_error:
      break;
    case K::state_changed:
    case K::recovered:
      on_alive(e.node, e.state, e.time);
      break;
    case K::lost:
      set_offline(e.node, e.time, "node guarding lost");
      break;
  }
}

bool Supervisor::on_frame(const can::Frame& frame, TimePoint now) {
  if (frame.is_error() || frame.is_extended()) return false;
  const std::uint32_t id = frame.id;
  if (id > canopen::cob::kEmcyBase && id <= canopen::cob::kEmcyBase + canopen::cob::kNodeIdMax) {
    return on_emcy(frame, static_cast<std::uint8_t>(id - canopen::cob::kEmcyBase), now);
  }
  if (id > canopen::cob::kNmtErrorControlBase &&
      id <= canopen::cob::kNmtErrorControlBase + canopen::cob::kNodeIdMax) {
    return on_error_control(frame, static_cast<std::uint8_t>(id - canopen::cob::kNmtErrorControlBase), now);
  }
  return false;
}

bool Supervisor::on_emcy(const can::Frame& frame, std::uint8_t node, TimePoint now) {
  Node& n = nodes_[node];
  if (!n.known) return false;
  const canopen::EmcyParse p = canopen::parse_emcy(frame);
  if (!p.ok()) return true;
  const device::EmcyInfo info = device::classify_emcy(n.family, p.emcy);
  Change c;
  c.kind = ChangeKind::emcy;
  c.node = node;
  c.at = now;
  c.nmt = n.nmt;
  c.emcy_code = p.emcy.error_code;
  c.emcy_text = device::describe_emcy(n.family, p.emcy);
  c.emcy_reset = info.error_reset;
  push(std::move(c));
  return true;
}

bool Supervisor::on_error_control(const can::Frame& frame, std::uint8_t node, TimePoint now) {
  Node& n = nodes_[node];
  if (!n.known) return false;
  const canopen::ErrorControlParse p = canopen::parse_error_control(frame);
  if (p.ok() && p.message.is_boot_up) {
    on_boot_up(frame, node, now);
    return true;
  }
  if (!n.watched) return true;
  n.last_frame_ns = frame.timestamp_ns;
  if (n.supervision.mode == Supervision::Mode::guarding) {
    guard_.on_frame(frame, now);
  } else if (n.supervision.mode == Supervision::Mode::heartbeat) {
    heartbeat_.on_frame(frame, now);
  } else if (p.ok()) {
    // Not supervised, but a heartbeat still proves the device is there.
    on_alive(node, p.message.state, now);
  }
  return true;
}

// The device reset: its volatile settings (and a heartbeat producer time
// not stored) are gone until the manager reconfigures it, so it drops back
// to "listen" and is no longer supervised.
void Supervisor::on_boot_up(const can::Frame& frame, std::uint8_t node, TimePoint now) {
  Node& n = nodes_[node];
  heartbeat_.on_frame(frame, now);
  guard_.on_frame(frame, now);
  heartbeat_.remove(node);
  guard_.remove(node);
  n.watched = false;
  n.online = false;
  n.heard = false;
  n.first_deadline = canopen::kNever;
  n.nmt = canopen::NmtState::boot_up;
  Change c;
  c.kind = ChangeKind::rebooted;
  c.node = node;
  c.at = now;
  c.nmt = canopen::NmtState::boot_up;
  c.reason = "rebooted";
  push(std::move(c));
}

void Supervisor::bus_lost(TimePoint now, const std::string& reason) {
  for (std::uint8_t id = canopen::cob::kNodeIdMin; id <= canopen::cob::kNodeIdMax; ++id) {
    const Node& n = nodes_[id];
    // set_offline reports each loss once: the consumer's later timeout is not news.
    if (n.watched || n.online) set_offline(id, now, reason);
  }
}

TimePoint Supervisor::process(TimePoint now, can::FrameSink& sink) {
  TimePoint next = std::min(heartbeat_.process(now), guard_.process(now, sink));
  for (std::uint8_t id = canopen::cob::kNodeIdMin; id <= canopen::cob::kNodeIdMax; ++id) {
    Node& n = nodes_[id];
    if (!n.watched || n.first_deadline == canopen::kNever) continue;
    if (now >= n.first_deadline) {
      set_offline(id, n.first_deadline, "no heartbeat since start");
    } else {
      next = std::min(next, n.first_deadline);
    }
  }
  return next;
}

std::vector<Supervisor::Change> Supervisor::take_changes() {
  std::vector<Change> out;
  out.swap(changes_);
  changes_.reserve(32);
  return out;
}

void apply(const Supervisor::Change& change, DeviceStatus& device, WallTime wall) {
  switch (change.kind) {
    case Supervisor::ChangeKind::online:
      device.online = true;
      device.nmt = change.nmt;
      if (device.state == DeviceState::offline) {
        device.state = DeviceState::operational;
        device.since = wall;
        device.last_error.clear();  // the loss is over; `since` tells when
      }
      break;
    case Supervisor::ChangeKind::offline:
      device.online = false;
      device.last_error = change.reason;
      if (device.state == DeviceState::operational) {
        device.state = DeviceState::offline;
        device.since = wall;
      }
      break;
    case Supervisor::ChangeKind::rebooted:
      device.online = false;
      device.nmt = canopen::NmtState::boot_up;
      ++device.boot_ups;
      device.last_error = change.reason;
      break;
    case Supervisor::ChangeKind::nmt_state:
      device.nmt = change.nmt;
      break;
    case Supervisor::ChangeKind::emcy:
      ++device.emcy_count;
      device.last_emcy_code = change.emcy_code;
      device.last_emcy_text = change.emcy_text;
      if (device.emcy_history.size() >= kEmcyHistory) device.emcy_history.erase(device.emcy_history.begin());
      device.emcy_history.push_back(EmcyRecord{change.emcy_code, change.emcy_text, wall});
      break;
  }
}

}  // namespace cobridge::bus
