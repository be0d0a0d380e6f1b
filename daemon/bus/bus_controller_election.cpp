// The bus controller's part in a hot-standby pair ([redundancy]).
//
// The election (canopen/master_election) runs beside everything else. As
// standby the controller listens: supervision follows the heartbeats, the hot
// path publishes every value, and nothing leaves but the election's frames
// (no NMT, SDO, LSS, SYNC or guarding; clients' commands are refused with
// the master's node-ID). Becoming master it starts as a second start does:
// discovery probes the configured node-IDs and each device's plan reads
// first and writes only what differs, so a device the other gateway
// configured is not written again, and no device is reset.
//
// A stranger's frames (docs/security.md "Raw CAN"): the election takes claims only from
// node-IDs that can be a gateway's, so the controller tells it which cannot
// (election_excluded: the configured devices, the devices known on the bus,
// the written node pool), every turn, so that a reload or a device given a
// node-ID counts at once. Role changes are logged within a budget (a storm
// of forged election frames must not bury the journal) with a count of what
// was left out.
#include "bus/bus_controller.hpp"

namespace cobridge::bus {

bool BusController::MasterGate::send(const can::Frame& frame) noexcept {
  if (impl.standby()) {
    ++refused;
    return false;
  }
  return impl.channel->send(frame);
}

void BusController::start_election(TimePoint now) {
  if (!config.redundancy || election) return;
  const config::RedundancySettings& r = *config.redundancy;
  canopen::MasterElectionConfig c;
  c.node_id = r.node_id;
  c.priority = r.priority;
  c.heartbeat = r.heartbeat;
  c.preempt = r.preempt;
  c.hold = r.hold;
  election.emplace(c);
  election->set_excluded(election_excluded());
  election->set_callback([this](const canopen::ElectionEvent& e) { on_election(e); });
  log->info("bus {}: hot standby as node {} (priority {}): asking for the active master", bus.name, r.node_id,
            r.priority);
  election->start(now, *channel);
  election_at = wall_now();
  dirty = true;
}

// Judged at the frame's arrival, not at the turn's clock: a thread
// preempted between reading its clock and reading its socket would stamp
// the master's heartbeat up to the preemption early, and ask for a
// negotiation (0x72) 1.5 periods after that stamp while the next heartbeat
// was still due (vcan_daemon_hot_standby on a loaded UML, master silent
// 100 ms).
bool BusController::election_frame(const can::Frame& frame, TimePoint arrived) {
  if (!election) return false;
  (void)election->on_frame(frame, arrived, *channel);
  return election->owns(frame);
}

// No device's node-ID, nor one the bus may give a device, is a gateway's.
// The default pool (1..127 less ours) is left out: it holds the other
// gateway's node-ID too (docs/operations.md "Hot standby").
canopen::NodeSet BusController::election_excluded() const {
  canopen::NodeSet s;
  for (const auto& m : devices) {
    if (m.st.node_id != 0) s.set(m.st.node_id);
    if (m.in_config && m.cfg.node_id) s.set(*m.cfg.node_id);
  }
  if (!bus.node_pool_default) {
    for (const std::uint8_t n : bus.node_pool) s.set(n);
  }
  if (config.redundancy) s.reset(config.redundancy->node_id);
  return s;
}

void BusController::update_election_exclusions() {
  const canopen::NodeSet now_excluded = election_excluded();
  if (now_excluded != election->excluded()) election->set_excluded(now_excluded);
}

void BusController::on_election(const canopen::ElectionEvent& e) {
  using canopen::MasterRole;
  election_at = wall_now();
  dirty = true;
  tell_outputs(e);
  log_role(e);
  switch (e.role) {
    case MasterRole::master:
      if (!discovery_started && channel->is_open()) {
        discovery->start(e.time);
        discovery_started = true;
      }
      check_configured_nodes(e.time);
      break;
    case MasterRole::standby:
      if (e.previous == MasterRole::master) {
        runners_abort();
        services->abort_all("this gateway is standby now");
      }
      break;
    case MasterRole::negotiating:
    case MasterRole::starting:
    case MasterRole::claiming:
      break;
  }
}

void BusController::log_role(const canopen::ElectionEvent& e) {
  using canopen::MasterRole;
  if (e.role == MasterRole::starting || e.role == MasterRole::claiming) return;
  if (!role_log.allow(e.time)) return;  // counted; report_suppressed_roles() says how many
  const std::string_view cause = canopen::to_string(e.cause);
  if (e.role == MasterRole::master) {
    log->warn("bus {}: this gateway is the bus's master now ({})", bus.name, cause);
  } else if (e.role == MasterRole::standby) {
    log->warn("bus {}: standby; the master is node {} ({})", bus.name, e.master_node, cause);
  } else {
    log->info("bus {}: negotiating the master role ({})", bus.name, cause);
  }
}

void BusController::report_suppressed_roles(TimePoint now) {
  const std::uint32_t n = role_log.take_suppressed(now);
  if (n == 0 || !election) return;
  log->warn("bus {}: {} more role changes not logged in the last {} s; now {} (master node {}, last cause: {})",
            bus.name, n, std::chrono::duration_cast<std::chrono::seconds>(kRoleLogWindow).count(),
            canopen::to_string(election->role()), election->master_node(),
            canopen::to_string(election->last_event().cause));
}

// Election frames that moved nothing (a stranger's, most likely): one line
// per window with the counts, never one per frame (a 0x76 every 200 ms).
TimePoint BusController::report_ignored_election_frames(TimePoint now) {
  if (!election) return kNever;
  if (ignored_report_at == kNever) ignored_report_at = now + kRoleLogWindow;
  if (now < ignored_report_at) return ignored_report_at;
  const canopen::ElectionCounters& c = election->counters();
  const canopen::ElectionCounters& was = ignored_reported;
  if (c.claims_ignored != was.claims_ignored || c.forces_ignored != was.forces_ignored ||
      c.forces_held != was.forces_held) {
    log->warn("bus {}: in the last {} s the election ignored {} claims/announcements naming no plausible gateway, "
              "{} forced negotiations (0x76) naming no live peer of higher rank, and held back {} from the peer "
              "(one handover a minute at most)",
              bus.name, std::chrono::duration_cast<std::chrono::seconds>(kRoleLogWindow).count(),
              c.claims_ignored - was.claims_ignored, c.forces_ignored - was.forces_ignored,
              c.forces_held - was.forces_held);
  }
  ignored_reported = c;
  ignored_report_at = now + kRoleLogWindow;
  return ignored_report_at;
}

void BusController::tell_outputs(const canopen::ElectionEvent& e) {
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

TimePoint BusController::run_standby(TimePoint now, TimePoint next) {
  next = std::min(next, supervisor.process(now, tx));  // its timers; a guarding request is refused
  follow_heard_devices();
  if (services->waiting() != 0) {
    services->abort_all(fmt::format("this gateway is standby on bus {}; the master is node {}", bus.name,
                                  election->master_node()));
  }
  for (auto& m : devices) next = std::min(next, m.emcy_log.report_due());
  return next;
}

void BusController::describe_role(BusStatus& s) const {
  if (!election) return;
  s.role = std::string(canopen::to_string(election->role()));
  s.master_node = election->master_node();
  s.peer_node = election->peer_node();
  s.election_cause = std::string(canopen::to_string(election->last_event().cause));
  s.election_at = election_at;
}

}  // namespace cobridge::bus
