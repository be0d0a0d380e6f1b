// BusController: set-up, the turn's parts and reload (see bus_controller.hpp).
// Control thread only; the constructor runs before the thread starts.
#include "bus/bus_controller.hpp"

namespace cobridge::bus {

BusController::BusController(const config::Config& config_in, std::size_t index,
                             const device::DeviceCatalog& catalog_in, StateStore& state_in,
                             BusManagerOptions options_in, TimelineSink* journal_in, TimelineSink::Kept kept,
                             TimePoint now, WallTime wall)
    : now_(now),
      wall_(wall),
      config(config_in),
      bus_index(index),
      catalog(catalog_in),
      state(state_in),
      options(options_in),
      journal(journal_in) {
  bus = config.buses.at(bus_index);
  log = sys::logger("gateway");
  build_devices();
  restore_timelines(std::move(kept));
}

void BusController::build_devices() {
  devices.clear();
  for (const auto& d : config.devices) {
    if (d.bus_index == bus_index) devices.push_back(make_managed(d));
  }
}

DeviceAgent BusController::make_managed(const config::Device& d) const {
  DeviceAgent m;
  m.cfg = d;
  m.st.name = d.name;
  m.st.bus = bus.name;
  m.st.node_id = d.node_id.value_or(0);
  m.st.identity.serial = d.serial;
  m.st.identity.vendor = d.vendor.value_or(0);
  m.st.identity.product = d.product.value_or(0);
  m.st.model = d.model;
  m.st.since = wall_now();
  return m;
}

DeviceAgent* BusController::find_device(std::string_view name) {
  for (auto& m : devices) {
    if (m.st.name == name) return &m;
  }
  return nullptr;
}

DeviceAgent* BusController::find_configured_node(std::uint8_t node) {
  for (auto& m : devices) {
    if (m.in_config && m.st.node_id == node) return &m;
  }
  return nullptr;
}

DeviceAgent* BusController::find_node(std::uint8_t node) {
  if (node == 0) return nullptr;
  for (auto& m : devices) {
    if (m.in_config && m.st.node_id == node && m.st.state != DeviceState::expected) return &m;
  }
  return nullptr;
}

void BusController::opened(TimePoint now) {
  started_at = now;
  publish_all();
}

// Discovery, the service executor and the SYNC producer, on the bus thread.
void BusController::start_components(TimePoint now) {
  DiscoveryOptions dopt;
  discovery = std::make_unique<Discovery>(tx, config, bus_index, state.on_bus(bus.name), dopt);
  follow_state_hold(now);
  services = std::make_unique<ServiceExecutor>(tx, bus.name, milliseconds(bus.lss_timeout_ms));
  if (bus.sync_period_ms > 0) {
    canopen::SyncProducer::Config sc;
    sc.period = milliseconds(bus.sync_period_ms);
    sc.overflow = bus.sync_counter;
    if (const auto ec = sync.configure(sc)) {
      log->error("bus {}: SYNC not produced: {}", bus.name, ec.message());
    } else {
      sync.start(now);
    }
  }
  log->info("bus {}: serving {} ({} configured devices)", bus.name, bus.interface, devices.size());
}

void BusController::follow_state_hold(TimePoint now) {
  std::string hold = state.hold();
  if (hold == state_hold) {
    discovery->hold_assignments(hold);
    return;
  }
  const bool released = hold.empty();
  state_hold = std::move(hold);
  dirty = true;
  if (released) {
    log->info("bus {}: the state file reads again; node-IDs are assigned from it", bus.name);
    restart_discovery(now);
    return;
  }
  log->warn("bus {}: no node-ID is assigned while the state file is held (cobridge status says why)", bus.name);
  discovery->hold_assignments(state_hold);
}

void BusController::restart_discovery(TimePoint now) {
  discovery = std::make_unique<Discovery>(tx, config, bus_index, state.on_bus(bus.name), DiscoveryOptions{});
  if (!discovery_started) return;
  discovery->start(now);
  for (const auto& m : devices)
    if (m.started && m.st.online) discovery->set_supervised(m.st.node_id, true);
}

TimePoint BusController::process(TimePoint now, bool lost) {
  if (handle_bus_events(now) || lost) {
    // A lost bus is news at once: status and the outputs hear of it
    // before the channel's reopen attempt, whose bind to an interface the
    // kernel is still deleting waits for the unregistration (2.5-3 s in
    // UML, vcan_daemon_adapter_hotplug).
    open_flag.store(channel->is_open());
    (void)handle_outputs(now);
    publish_if_dirty();
  }
  if (config.redundancy && !election && channel->is_open()) start_election(now);
  if (!discovery_started && channel->is_open() && !standby()) {
    // Not before: probes sent to a missing interface would mark every
    // device absent; nor as standby, whose probes are the master's.
    discovery->start(now);
    discovery_started = true;
    check_configured_nodes(now);
  }
  return run_components(now);
}

TimePoint BusController::settle(TimePoint now) {
  update_ready(now);
  publish_if_dirty();
  return flush_timelines(now);
}

void BusController::finish_run(TimePoint now) {
  (void)flush_timelines(now, true);
  sync.stop();
  runners_abort();
  services->abort_all("the bus stopped");
  open_flag.store(false);
  log->info("bus {}: stopped", bus.name);
}

void BusController::apply_reload(config::Config next, TimePoint now) {
  const config::Bus* nb = next.find_bus(bus.name);
  if (nb == nullptr) {
    log->warn("bus {}: not in the new configuration; kept as it is until restart", bus.name);
    return;
  }
  std::size_t new_index = 0;  // find_bus found it
  while (next.buses[new_index].name != bus.name) ++new_index;
  if (nb->interface != bus.interface) {
    log->warn("bus {}: a new interface ({}) needs a restart; kept {}", bus.name, nb->interface, bus.interface);
  }
  const std::string interface = bus.interface;
  config = std::move(next);
  bus_index = new_index;
  bus = config.buses[bus_index];
  bus.interface = interface;
  discovery->reload(config, bus_index, state.on_bus(bus.name));

  std::vector<DeviceAgent> old = std::move(devices);
  devices.clear();
  for (const auto& d : config.devices) {
    if (d.bus_index != bus_index) continue;
    auto it = std::find_if(old.begin(), old.end(), [&](const DeviceAgent& o) { return o.in_config && o.cfg.name == d.name; });
    if (it == old.end()) {
      devices.push_back(make_managed(d));
      continue;
    }
    DeviceAgent m = std::move(*it);
    old.erase(it);
    m.cfg = d;
    if (m.started && m.description != nullptr && m.profile) {
      // Reconfigure only if the settings as applied would differ, or over
      // a client's value kept under on_config_drift = "keep".
      const auto plan = make_config_plan(m.cfg, *m.description, *m.profile, m.st.node_id);
      if (!plan.ok() || !m.plan || plan.plan->fingerprint != m.plan->fingerprint || !m.st.drift.empty()) {
        log->info("bus {}: device {}: {}; reconfiguring", bus.name, m.st.name,
                  m.st.drift.empty() ? "settings changed" : "configuration differs");
        m.plan.reset();
        m.started = false;  // the plan puts it in pre-operational: not a surprise
        supervisor.listen(m.st.node_id, m.profile->family);
        m.want_configuration(now);
      }
    }
    devices.push_back(std::move(m));
  }
  for (auto& o : old) {
    if (o.in_config && o.st.node_id != 0) {
      supervisor.unwatch(o.st.node_id);
      discovery->set_supervised(o.st.node_id, false);
    }
    if (!o.in_config) devices.push_back(std::move(o));  // still on the bus
  }
  follow_state_hold(now);  // after the devices: a new discovery learns which are supervised
  dirty = true;
  // The moment the bus thread runs with the new settings (SIGHUP only asks).
  log->info("bus {}: new configuration applied", bus.name);
}

}  // namespace cobridge::bus
