// The bus controller as standby of a hot-standby pair: what it learns by
// listening (StandbyListener, standby_listener.hpp) applied to its devices,
// so that its outputs are live and a takeover finds what the master knew.
// It sends nothing (bus_controller_election.cpp gates every send).
// A device heard in operation is announced to the outputs with the mapping
// its plan sets, and remembered in this gateway's state store with the
// plan's fingerprint, as the master remembered it: a takeover starts from
// that table as a second start does, with no commissioning and no writes.
// Control thread only.
#include "bus/bus_controller.hpp"
#include "bus/description_choice.hpp"

namespace cobridge::bus {

void BusController::listen_as_standby(const can::Frame& frame, TimePoint now) {
  const auto heard = listener.hear(frame, now, milliseconds(bus.sdo_timeout_ms));
  using Kind = StandbyListener::Heard::Kind;
  if (heard.kind == Kind::state) {
    if (DeviceAgent* m = find_configured_node(heard.node); m != nullptr && m->note_heard_state(heard.operational)) {
      dirty = true;  // the status shows it
    }
  } else if (heard.kind == Kind::identity) {
    for (auto& m : devices) {
      if (!m.note_identity_heard(heard.identity, heard.node)) continue;
      dirty = true;
      log->info("bus {}: standby: device {} is at node {} (the master read its identity)", bus.name, m.st.name,
                heard.node);
    }
  }
}

// The standby's outputs are live before any takeover: each configured
// device heard in operation is announced with the TPDO mapping its plan
// sets, which the master has configured and verified.
void BusController::follow_heard_devices() {
  for (auto& m : devices) {
    if (!m.to_follow()) continue;
    if (m.description == nullptr) {
      auto chosen = description_from_config(catalog, m.cfg, m.st.identity);
      if (!chosen.ok()) continue;
      m.description = chosen->description;
      m.profile = chosen->profile;
    }
    const auto plan = make_config_plan(m.cfg, *m.description, *m.profile, m.st.node_id);
    if (!plan.ok()) continue;
    m.followed = true;
    remember_followed(m, plan.plan->fingerprint);
    if (options.observer == nullptr) continue;
    std::vector<std::uint32_t> tpdo1, tpdo2;
    for (const auto& step : plan.plan->steps) {
      if (step.kind != StepKind::tpdo_mapping) continue;
      (step.tpdo == 1 ? tpdo1 : tpdo2) = step.mapping;
    }
    options.observer->on_device_configured(m.st, tpdo1, tpdo2);
    log->info("bus {}: standby: decoding device {} at node {} as the configuration maps it", bus.name, m.st.name,
              m.st.node_id);
  }
}

// The device runs with the plan's settings (the master started it after
// applying them): the same record the master keeps.
void BusController::remember_followed(const DeviceAgent& m, const std::string& fingerprint) {
  if (m.st.identity.serial != 0) remember_assignment(m, fingerprint);
}

}  // namespace cobridge::bus
