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
#include "config/known_models.hpp"
#include "families/family.hpp"

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

// The standby's outputs are live before any takeover: each configured
// device heard in operation is announced with the TPDO mapping its plan
// sets, which the master has configured and verified. The description
// comes from the identity the configuration names (vendor and product, or
// the model), or the one remembered from this gateway's own tenure.
void BusManager::Impl::follow_heard_devices() {
  if (options.observer == nullptr) return;
  for (auto& m : devices) {
    if (m.followed || !m.in_config || m.st.node_id == 0 || !m.heard_operational) continue;
    if (m.description == nullptr && !describe_from_config(m)) continue;
    const auto plan = make_config_plan(m.cfg, *m.description, *m.profile, m.st.node_id);
    if (!plan.ok()) continue;
    std::vector<std::uint32_t> tpdo1, tpdo2;
    for (const auto& step : plan.plan->steps) {
      if (step.kind != StepKind::tpdo_mapping) continue;
      (step.tpdo == 1 ? tpdo1 : tpdo2) = step.mapping;
    }
    options.observer->on_device_configured(m.st, tpdo1, tpdo2);
    m.followed = true;
    log->info("bus {}: standby: decoding device {} at node {} as the configuration maps it", bus.name, m.st.name,
              m.st.node_id);
  }
}

void BusManager::Impl::note_heartbeat(const can::Frame& frame) {
  if (frame.is_extended() || frame.is_rtr() || frame.len != 1) return;
  if (frame.id <= canopen::cob::kNmtErrorControlBase || frame.id > canopen::cob::kNmtErrorControlBase + 127) return;
  const auto node = static_cast<std::uint8_t>(frame.id - canopen::cob::kNmtErrorControlBase);
  if (Managed* m = find_configured_node(node)) {
    m->heard_operational = (frame.data[0] & 0x7F) == static_cast<std::uint8_t>(canopen::NmtState::operational);
  }
}

// The first loaded description of the model's vendor and family: for a
// model whose product code is not checkable (ifm, F§7.3).
static const device::DeviceDescription* description_of_family(const device::DeviceCatalog& catalog,
                                                              const config::KnownModel& known) {
  for (const auto* d : catalog.all()) {
    if (d->device_info.vendor_number != known.vendor) continue;
    const auto profile = device::family_profile_for(*d);
    if (profile && profile->family == &device::families::family(known.family)) return d;
  }
  return nullptr;
}

bool BusManager::Impl::describe_from_config(Managed& m) {
  const auto& id = m.st.identity;
  const config::KnownModel* known = m.cfg.model.empty() ? nullptr : config::find_model(m.cfg.model);
  const device::DeviceDescription* d = nullptr;
  if (id.vendor != 0 && id.product != 0) {
    const auto candidates = catalog.candidates(id.vendor, id.product, std::nullopt);
    if (!candidates.empty()) d = candidates.front();
  } else if (known != nullptr && !known->products.empty()) {
    const auto candidates = catalog.candidates(known->vendor, known->products.front(), std::nullopt);
    if (!candidates.empty()) d = candidates.front();
  }
  if (d == nullptr && known != nullptr) d = description_of_family(catalog, *known);
  if (d == nullptr) return false;
  auto profile = device::family_profile_for(*d);
  if (!profile) return false;
  m.description = d;
  m.profile = profile;
  return true;
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
