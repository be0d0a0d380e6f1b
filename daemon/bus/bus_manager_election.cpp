// The bus manager's part in a hot-standby pair ([redundancy]).
//
// The election (canopen/master_election) runs beside everything else. As
// standby the manager listens: supervision follows the heartbeats, the hot
// path publishes every value, and nothing leaves but the election's frames
// (no NMT, SDO, LSS, SYNC or guarding; clients' commands are refused with
// the master's node-ID). Becoming master it starts as a second start does:
// discovery probes the configured node-IDs and each device's plan reads
// first and writes only what differs, so a device the other gateway
// configured is not written again, and no device is reset.
#include "bus/bus_manager_impl.hpp"

namespace cobridge::gateway {

bool BusManager::Impl::MasterGate::send(const can::Frame& frame) noexcept {
  if (impl.standby()) {
    ++refused;
    return false;
  }
  return impl.channel->send(frame);
}

void BusManager::Impl::start_election(TimePoint now) {
  if (!config.redundancy || election) return;
  const config::RedundancySettings& r = *config.redundancy;
  canopen::MasterElectionConfig c;
  c.node_id = r.node_id;
  c.priority = r.priority;
  c.heartbeat = r.heartbeat;
  c.preempt = r.preempt;
  c.hold = r.hold;
  election.emplace(c);
  election->set_callback([this](const canopen::ElectionEvent& e) { on_election(e); });
  log->info("bus {}: hot standby as node {} (priority {}): asking for the active master", bus.name, r.node_id,
            r.priority);
  election->start(now, *channel);
  election_at = wall_now();
  dirty = true;
}

bool BusManager::Impl::election_frame(const can::Frame& frame, TimePoint now) {
  if (!election) return false;
  (void)election->on_frame(frame, now, *channel);
  return election->owns(frame);
}

void BusManager::Impl::on_election(const canopen::ElectionEvent& e) {
  using canopen::MasterRole;
  election_at = wall_now();
  dirty = true;
  const std::string_view cause = canopen::to_string(e.cause);
  tell_outputs(e);
  switch (e.role) {
    case MasterRole::master:
      log->warn("bus {}: this gateway is the bus's master now ({})", bus.name, cause);
      if (!discovery_started && channel->is_open()) {
        discovery->start(e.time);
        discovery_started = true;
      }
      check_configured_nodes(e.time);
      break;
    case MasterRole::standby:
      log->warn("bus {}: standby; the master is node {} ({})", bus.name, e.master_node, cause);
      if (e.previous == MasterRole::master) {
        runners_abort();
        remote->abort_all("this gateway is standby now");
      }
      break;
    case MasterRole::negotiating:
      log->info("bus {}: negotiating the master role ({})", bus.name, cause);
      break;
    case MasterRole::starting:
    case MasterRole::claiming:
      break;
  }
}

void BusManager::Impl::tell_outputs(const canopen::ElectionEvent& e) {
  if (options.observer == nullptr) return;
  BusRole r;
  r.kind = e.role == canopen::MasterRole::master    ? BusRole::Kind::master
           : e.role == canopen::MasterRole::standby ? BusRole::Kind::standby
                                                    : BusRole::Kind::undecided;
  r.own_node = config.redundancy ? config.redundancy->node_id : 0;
  r.master_node = e.master_node;
  r.peer_node = election->peer_node();
  r.cause = std::string(canopen::to_string(e.cause));
  r.since_ns = static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(election_at.time_since_epoch()).count());
  options.observer->on_role_changed(r);
}

TimePoint BusManager::Impl::run_standby(TimePoint now, TimePoint next) {
  next = std::min(next, supervisor.process(now, tx));  // its timers; a guarding request is refused
  follow_heard_devices();
  if (remote->waiting() != 0) {
    remote->abort_all(fmt::format("this gateway is standby on bus {}; the master is node {}", bus.name,
                                  election->master_node()));
  }
  for (auto& m : devices) next = std::min(next, m.emcy_log.report_due());
  return next;
}

void BusManager::Impl::describe_role(BusStatus& s) const {
  if (!election) return;
  s.role = std::string(canopen::to_string(election->role()));
  s.master_node = election->master_node();
  s.peer_node = election->peer_node();
  s.election_cause = std::string(canopen::to_string(election->last_event().cause));
  s.election_at = election_at;
}

}  // namespace cobridge::gateway
