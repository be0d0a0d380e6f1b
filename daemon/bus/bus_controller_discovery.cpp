// BusController: discovery events, and the identity check of buses
// without discovery. Control thread only.
#include "bus/bus_controller.hpp"

#include "base/number_text.hpp"
#include "bus/description_choice.hpp"

namespace cobridge::bus {

void BusController::check_configured_nodes(TimePoint now) {
  if (bus.discovery) return;
  for (auto& m : devices) {
    if (!m.in_config || m.st.node_id == 0 || m.runner) continue;
    if (m.description == nullptr) supervisor.listen(m.st.node_id, nullptr);
    m.want_identity(now, false);
  }
}

void BusController::start_identity_reads(TimePoint now) {
  if (!channel->is_open()) return;
  for (auto& m : devices) {
    if (!m.identity_due(now)) continue;
    if (m.st.node_id == services->sdo_node()) continue;  // a client's transfer runs on it
    m.begin_identity();
    m.ident = std::make_unique<IdentityReader>(sdo_of(m));
    if (m.ident->start(now)) {
      m.ident.reset();
      m.want_identity(now + kConfigureRetryDelay, false);
    }
  }
}
void BusController::finish_identity(DeviceAgent& m, TimePoint now) {
  const std::unique_ptr<IdentityReader> reader = std::move(m.ident);
  const bool boot_up = m.take_identity_boot_up();
  const auto retry = now + std::chrono::seconds(bus.discovery_period_s);
  switch (m.judge_identity(reader->identity())) {
    case IdentityVerdict::unanswered:
      m.st.last_error = "no answer at node " + std::to_string(m.st.node_id) + " (0x1018: " +
                        reader->error().message() + "); discovery is off, asking again in " +
                        std::to_string(bus.discovery_period_s) + " s";
      dirty = true;
      m.want_identity(retry, false);
      return;
    case IdentityVerdict::other_serial:
      m.st.last_error = "node " + std::to_string(m.st.node_id) + " holds serial " +
                        std::to_string(reader->identity()->serial) + ", not the configured " +
                        std::to_string(m.cfg.serial) + "; not configured";
      log->warn("bus {}: device {}: {}", bus.name, m.st.name, m.st.last_error);
      add_problem("device " + m.st.name + ": " + m.st.last_error, m.st.name);
      set_state(m, DeviceState::failed);
      m.want_identity(retry, false);
      return;
    case IdentityVerdict::identified:
      break;
  }
  const canopen::LssAddress& id = *reader->identity();
  DiscoveryEvent e;
  e.kind = DiscoveryEventKind::identified;
  e.node_id = e.target_node_id = m.st.node_id;
  e.at_target = true;
  e.boot_up = boot_up;
  e.identity = id;
  e.device = m.st.name;
  on_identified(e, now);
}

void BusController::on_sign_of_life(DeviceAgent& m, TimePoint now) {
  const bool lost = m.st.state == DeviceState::offline ||
                    (m.st.state == DeviceState::failed && m.failed_unanswered);
  if (!lost || m.description == nullptr || m.runner || m.want_configure) return;
  log->info("bus {}: device {} (node {}) sends again while {}; checking its configuration", bus.name, m.st.name,
            m.st.node_id, to_string(m.st.state));
  m.replan(now);
}

void BusController::on_discovery_event(const DiscoveryEvent& e, TimePoint now) {
  switch (e.kind) {
    case DiscoveryEventKind::identified:
      on_identified(e, now);
      break;
    case DiscoveryEventKind::commissioned: {
      log->info("bus {}: {}", bus.name, e.text);
      if (DeviceAgent* m = e.device.empty() ? nullptr : find_device(e.device)) add_event(*m, TimelineKind::lss, e.text);
      if (const Error err = record_assignment(state, bus.name, e))
        log->error("bus {}: state file {}", bus.name, err.to_string());
      break;
    }
    case DiscoveryEventKind::clash_detected:
      log->warn("bus {}: {}", bus.name, e.text);
      add_problem(e.text, "", e.node_id);
      break;
    case DiscoveryEventKind::problem:
      log->warn("bus {}: {}", bus.name, e.text);
      add_problem(e.text, e.device);
      break;
    case DiscoveryEventKind::retry:
      on_retry(e);
      break;
    case DiscoveryEventKind::clash_resolved:
      log->info("bus {}: {}", bus.name, e.text);
      if (board.clear_clash(e.node_id)) dirty = true;
      break;
  }
}

void BusController::on_identified(const DiscoveryEvent& e, TimePoint now) {
  const std::string& name = !e.device.empty() ? e.device : e.replaces;
  DeviceAgent* m = name.empty() ? nullptr : find_device(name);
  if (m == nullptr) {
    note_unknown(e);
    return;
  }
  if (!e.replaces.empty() && m->st.identity.serial != e.identity.serial) {
    log->info("bus {}: device serial {} takes the place of {} (serial {})", bus.name, e.identity.serial,
              e.replaces, e.replaced.serial);
  }
  if (drop_unknown_entry(e)) m = find_device(name);  // the erase moved the elements
  switch (m->judge_identified(e, !state_hold.empty())) {
    case IdentifiedVerdict::held_in_place:
      m->st.identity = e.identity;
      set_state(*m, DeviceState::identified,
                "at node " + std::to_string(e.node_id) + ", not moved to node " + std::to_string(e.target_node_id) +
                    ": no node-ID is assigned while the state file is held");
      return;
    case IdentifiedVerdict::moving:  // reported `identified` again at the target
      set_state(*m, DeviceState::commissioning);
      m->st.identity = e.identity;
      return;
    case IdentifiedVerdict::running_fine:
      discovery->set_supervised(e.node_id, true);
      return;
    case IdentifiedVerdict::on_its_way:
      if (!m->runner) m->not_before = now;
      return;
    case IdentifiedVerdict::reconfigure:
      break;
  }
  reconfigure_identified(*m, e, now);
}

// A device first reported as unknown (before the swap was decided) is now a
// configured one: drops its "unknown-" entry. True when there was one.
bool BusController::drop_unknown_entry(const DiscoveryEvent& e) {
  for (const auto& u : devices) {
    if (u.is_unknown(e.identity) && options.observer != nullptr) options.observer->on_device_removed(u.st);
  }
  const auto dropped = std::erase_if(devices, [&](const DeviceAgent& u) { return u.is_unknown(e.identity); });
  if (dropped != 0) dirty = true;
  return dropped != 0;
}

// The device is at its node-ID: remember it there, supervise it and
// configure it from the start.
void BusController::reconfigure_identified(DeviceAgent& m, const DiscoveryEvent& e, TimePoint now) {
  if (m.st.node_id != 0 && m.st.node_id != e.node_id) {
    add_event(m, TimelineKind::node_id,
              "node-ID " + std::to_string(m.st.node_id) + " -> " + std::to_string(e.node_id) + " (serial " +
                  std::to_string(e.identity.serial) + ")");
  }
  if (m.st.identity.serial != 0 && m.st.identity.serial != e.identity.serial) {
    add_event(m, TimelineKind::node_id,
              "serial " + std::to_string(e.identity.serial) + " takes the place of serial " +
                  std::to_string(m.st.identity.serial));
  }
  m.st.identity = e.identity;
  m.st.node_id = e.node_id;
  m.st.next_retry = {};  // commissioned (the failures so far stay counted)
  // Remember where it is even before it is configured (a restart then
  // needs no scan); a replacement also drops the replaced device's line.
  if (const Error err = record_assignment(state, bus.name, e))
    log->error("bus {}: state file {}", bus.name, err.to_string());
  if (!resolve_description(m)) {
    set_state(m, DeviceState::failed);
    return;
  }
  supervisor.listen(e.node_id, m.profile->family);
  discovery->set_supervised(e.node_id, true);
  set_state(m, DeviceState::identified);
  drop_runner(m, "the device was identified anew");
  m.replan(now);
}

void BusController::on_retry(const DiscoveryEvent& e) {
  log->warn("bus {}: {}", bus.name, e.text);
  // Every failed commissioning step comes here (Commissioning::retry_later).
  DeviceAgent* m = e.device.empty() ? nullptr : find_device(e.device);
  if (m == nullptr) {
    capture("lss failed", e.device);
    add_problem(e.text, "");
    return;
  }
  // One problem line per device, the latest try's; cleared once it is operational.
  if (board.clear_device(e.device)) dirty = true;
  add_problem(e.text, e.device);
  m->st.commission_failures = e.count;
  m->st.next_retry = wall_now() + std::chrono::duration_cast<std::chrono::system_clock::duration>(e.retry_in);
  m->st.last_error = e.text;
  if (m->st.identity.serial == 0) m->st.identity = e.identity;
  add_event(*m, TimelineKind::lss, e.text, capture("lss failed", m->st.name));
  set_state(*m, DeviceState::failed);
  dirty = true;
}

void BusController::note_unknown(const DiscoveryEvent& e) {
  for (auto& m : devices) {
    if (m.is_unknown(e.identity)) {
      m.st.node_id = e.node_id;
      dirty = true;
      return;
    }
  }
  DeviceAgent m;
  m.in_config = false;
  m.st.name = "unknown-" + std::to_string(e.identity.serial);
  m.st.bus = bus.name;
  m.st.node_id = e.node_id;
  m.st.identity = e.identity;
  m.st.state = DeviceState::identified;
  m.st.since = wall_now();
  if (const auto* d = catalog.select(e.identity.vendor, e.identity.product, e.identity.revision)) {
    m.st.model = d->device_info.product_name;
    m.st.family = d->selection.family;
  }
  m.st.last_error = e.text.empty() ? "not in the configuration" : e.text;
  devices.push_back(std::move(m));
  dirty = true;
}

bool BusController::resolve_description(DeviceAgent& m) {
  auto chosen = choose_description(catalog, m.cfg, m.st.identity);
  if (!chosen.ok()) {
    m.st.last_error = chosen.error().message;
    log->error("bus {}: device {}: {}", bus.name, m.st.name, m.st.last_error);
    add_problem("device " + m.st.name + ": " + m.st.last_error, m.st.name);
    return false;
  }
  m.description = chosen->description;
  m.profile = chosen->profile;
  m.st.model = m.description->device_info.product_name;
  m.st.family = m.description->selection.family;
  return true;
}

}  // namespace cobridge::bus
