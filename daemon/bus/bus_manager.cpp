// BusManager: construction, the control thread's loop, the hand-over of
// commands from other threads, and the public API (see bus_manager.hpp).
#include "bus/bus_manager_impl.hpp"
#include "bus/capture_writer.hpp"

#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <cerrno>

namespace cobridge::bus {

BusManager::Impl::Impl(const config::Config& config_in, std::size_t index, const device::DeviceCatalog& catalog_in,
     StateStore& state_in, BusManagerOptions options_in)
    : config(config_in),
      bus_index(index),
      catalog(catalog_in),
      state(state_in),
      options(options_in),
      clock(options_in.clock != nullptr ? *options_in.clock : system_bus_clock()) {
  bus = config.buses.at(bus_index);
  log = sys::logger("gateway");
  build_devices();
  restore_timelines();
  wake_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
}

void BusManager::Impl::build_devices() {
  devices.clear();
  for (const auto& d : config.devices) {
    if (d.bus_index == bus_index) devices.push_back(make_managed(d));
  }
}

DeviceAgent BusManager::Impl::make_managed(const config::Device& d) const {
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

DeviceAgent* BusManager::Impl::find_device(std::string_view name) {
  for (auto& m : devices) {
    if (m.st.name == name) return &m;
  }
  return nullptr;
}

DeviceAgent* BusManager::Impl::find_configured_node(std::uint8_t node) {
  for (auto& m : devices) {
    if (m.in_config && m.st.node_id == node) return &m;
  }
  return nullptr;
}

DeviceAgent* BusManager::Impl::find_node(std::uint8_t node) {
  if (node == 0) return nullptr;
  for (auto& m : devices) {
    if (m.in_config && m.st.node_id == node && m.st.state != DeviceState::expected) return &m;
  }
  return nullptr;
}

BusManager::Impl::~Impl() {
  if (wake_fd >= 0) ::close(wake_fd);
}

Error BusManager::Impl::open_port() {
  const std::string where = "bus " + bus.name;
  if (options.port != nullptr) {
    channel = options.port;
    return {};
  }
  can::SocketCanConfig cc;
  cc.interface = bus.interface;
  cc.wait_for_interface = true;  // a missing adapter is reported and waited for
  cc.reopen_backoff_max = kReopenBackoffMax;
  cc.receive_buffer_bytes = kControlReceiveBuffer;
  socket = std::make_unique<can::SocketCanChannel>(cc);
  if (Error err = socket->open()) {
    socket.reset();
    err.where = err.where.empty() ? where : where + ": " + err.where;
    return err;
  }
  // What the control plane needs; the TPDOs go to the hot path's own socket.
  static constexpr std::array<can::Filter, 6> kFilters{{
      {canopen::cob::kSdoTxBase, 0x780, false},            // SDO responses 0x580..0x5FF
      {canopen::cob::kSdoRxBase, 0x780, false},            // other clients' SDO requests 0x600..0x67F
      {canopen::cob::kMasterNodeId & ~0x7U, 0x7F8, false},  // the master election 0x70..0x77 ([redundancy])
      can::Filter::exact(canopen::cob::kLssSlaveToMaster),  // LSS 0x7E4
      {canopen::cob::kNmtErrorControlBase, 0x780, false},   // boot-up/heartbeat/guarding 0x700..0x77F
      {canopen::cob::kEmcyBase, 0x780, false},              // EMCY 0x081..0x0FF
  }};
  if (Error ferr = socket->set_filters(kFilters)) {
    socket.reset();
    ferr.where = ferr.where.empty() ? where : where + ": " + ferr.where;
    return ferr;
  }
  channel = socket.get();
  return {};
}

Error BusManager::Impl::start() {
  if (wake_fd < 0)
    return Error(Errc::kUnavailable, "no eventfd for the control thread", "bus " + bus.name,
                 std::make_error_code(std::errc::too_many_files_open));
  if (Error e = open_port()) return e;
  started_at = steady_now();
  publish_all();
  stop_requested.store(false);
  running.store(true);
  thread = std::thread([this] { run(); });
  return {};
}

void BusManager::Impl::stop() {
  if (!thread.joinable()) return;
  stop_requested.store(true);
  wake();
  thread.join();
  running.store(false);
}

void BusManager::Impl::wake() noexcept {
  if (wake_fd < 0) return;
  const std::uint64_t one = 1;
  [[maybe_unused]] const auto n = ::write(wake_fd, &one, sizeof one);
}

void BusManager::Impl::run() {
  start_components(steady_now());
  while (!stop_requested.load(std::memory_order_relaxed)) {
    TimePoint now = steady_now();
    const TimePoint next = turn(now);
    wait(now, next);
  }
  finish_run();
}

TimePoint BusManager::Impl::turn(TimePoint& now) {
  take_commands(now);
  // A wake-up for a command that found the socket empty then, in a turn that
  // runs past a deadline (the thread preempted after poll: a loaded host):
  // frames came meanwhile, and a heartbeat left unread would count as silence
  // (a returning standby negotiated while the master's heartbeat sat unread,
  // vcan_daemon_hot_standby 2026-11-30).
  if (now >= polled_for) rx_ready = true;
  const bool lost = receive(rx_frames, now);  // the interface went down in this turn
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
  loop_alive.store(now.time_since_epoch().count(), std::memory_order_relaxed);

  TimePoint next = run_components(now);
  // Handling the components' output may have started new work (a plan,
  // a reconfiguration): give it a turn at once rather than a poll later.
  // That handling can take milliseconds (the state store's fsync of a
  // node-ID just assigned): what the socket took in meanwhile is
  // dispatched before a component judges its timeouts at the new time, or
  // a Fastscan answer waiting there would count as silence. (LssMaster
  // judges an answer by its kernel stamp: one that came in time is in
  // time, however late the turn gets to it.)
  while (handle_outputs(now)) {
    now = steady_now();
    rx_ready = true;
    if (receive(rx_frames, now)) open_flag.store(channel->is_open());
    next = run_components(now);
  }
  update_ready(now);
  publish_if_dirty();
  return std::min(next, flush_timelines(now));
}

void BusManager::Impl::finish_run() {
  (void)flush_timelines(steady_now(), true);
  sync.stop();
  runners_abort();
  services->abort_all("the bus stopped");
  channel->close();
  open_flag.store(false);
  log->info("bus {}: stopped", bus.name);
}

// Discovery, the service executor and the SYNC producer, on the bus thread.
void BusManager::Impl::start_components(TimePoint now) {
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

void BusManager::Impl::follow_state_hold(TimePoint now) {
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

void BusManager::Impl::restart_discovery(TimePoint now) {
  discovery = std::make_unique<Discovery>(tx, config, bus_index, state.on_bus(bus.name), DiscoveryOptions{});
  if (!discovery_started) return;
  discovery->start(now);
  for (const auto& m : devices)
    if (m.started && m.st.online) discovery->set_supervised(m.st.node_id, true);
}

// Receives and dispatches what the socket holds; true when the interface
// went down meanwhile. Only when poll saw the socket readable (or never
// asked): an empty recvmmsg is a system call per turn, and a turn per client
// command.
bool BusManager::Impl::receive(std::span<can::Frame> frames, TimePoint now) {
  bool lost = false;
  for (std::size_t batch = 0; rx_ready && batch < kMaxReceiveBatches; ++batch) {
    const std::size_t n = channel->receive(frames);
    for (std::size_t i = 0; i < n; ++i) dispatch(frames[i], now);
    lost = handle_bus_events(now) || lost;
    if (n < frames.size()) break;
  }
  return lost;
}

// `now` is the turn's clock reading, not a fresh one: a clock read is a
// system call under UML and this turn is on a client's SDO round trip.
// A deadline is then met late by at most the turn's own work
// (microseconds), against the millisecond rounding of poll's timeout.
void BusManager::Impl::wait(TimePoint now, TimePoint next) {
  milliseconds timeout = kMaxPollWait;
  polled_for = std::min(next, now + kMaxPollWait);
  if (next != kNever) {
    const auto until = std::chrono::ceil<milliseconds>(next - now);
    timeout = std::clamp(until, milliseconds(0), kMaxPollWait);
  }
  // The wake-up, then the CAN socket.
  poll_fds.clear();
  poll_fds.push_back({wake_fd, POLLIN, 0});
  const bool can = channel->fd() >= 0;
  if (can) poll_fds.push_back({channel->fd(), POLLIN, 0});
  const int r = ::poll(poll_fds.data(), poll_fds.size(), static_cast<int>(timeout.count()));
  // A turn that poll ended for a deadline reads the socket all the same:
  // under load the thread may run long after poll returned, and a heartbeat
  // that came meanwhile must be dispatched before the election and
  // supervision judge their timeouts at the turn's clock (a standby asked
  // for a negotiation, 0x72, while the master's heartbeat sat unread). Only
  // a client command's wake-up alone skips the empty read (the hop an SDO
  // read through the daemon pays, docs/performance.md).
  const bool woken_only = r > 0 && (poll_fds[0].revents & POLLIN) != 0 && (!can || poll_fds[1].revents == 0);
  rx_ready = !woken_only || !can;
  if (r > 0 && (poll_fds[0].revents & POLLIN) != 0) {
    std::uint64_t v = 0;
    [[maybe_unused]] const auto n = ::read(wake_fd, &v, sizeof v);
  }
}

void BusManager::Impl::take_commands(TimePoint now) {
  bool commission = false;
  std::optional<config::Config> reload_config;
  std::deque<DeviceCommand> commands;
  std::deque<std::pair<ServiceRequest, std::shared_ptr<ServiceReplies>>> clients;
  std::vector<std::pair<std::string, std::string>> acks;
  {
    const std::lock_guard lock(mutex);
    commission = std::exchange(commission_requested, false);
    acks.swap(pending_acks);
    reload_config = std::exchange(pending_reload, std::nullopt);
    commands.swap(pending_commands);
    clients.swap(pending_services);
  }
  for (auto& [c, to] : clients) services->add(std::move(c), std::move(to), now);
  if (commission) discovery->request_commission();
  for (const auto& [device, caller] : acks) acknowledge_contested(device, caller, now);
  if (reload_config) apply_reload(std::move(*reload_config), now);
  for (auto& c : commands) start_command(std::move(c), now);
}

void BusManager::Impl::apply_reload(config::Config next, TimePoint now) {
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

BusManager::BusManager(const config::Config& config, std::size_t bus_index, const device::DeviceCatalog& catalog,
                       StateStore& state, BusManagerOptions options)
    : impl_(std::make_unique<Impl>(config, bus_index, catalog, state, options)) {}

BusManager::~BusManager() {
  stop();
  close();
}

Error BusManager::start() {
  if (impl_->thread.joinable())
    return Error(Errc::kFailed, "already started", "bus " + impl_->bus.name,
                 std::make_error_code(std::errc::device_or_resource_busy));
  ServiceBus rb{impl_->bus.name, impl_->bus.interface, static_cast<unsigned>(impl_->bus_index + 1)};
  const config::ServiceAccess access = impl_->config.services;
  if (Error e = impl_->start()) return e;
  if (impl_->options.registry != nullptr) impl_->options.registry->add(*this, std::move(rb), access);
  return {};
}

void BusManager::stop() {
  if (impl_->options.registry != nullptr) impl_->options.registry->remove(*this);
  impl_->stop();
}

Error BusManager::open() {
  if (impl_->thread.joinable() || impl_->running.load())
    return Error(Errc::kFailed, "already started", "bus " + impl_->bus.name,
                 std::make_error_code(std::errc::device_or_resource_busy));
  if (Error e = impl_->open_port()) return e;
  impl_->started_at = impl_->steady_now();
  impl_->publish_all();
  impl_->running.store(true);
  impl_->start_components(impl_->started_at);
  return {};
}

canopen::TimePoint BusManager::turn(canopen::TimePoint now) {
  impl_->rx_ready = true;  // no poll said otherwise
  return impl_->turn(now);
}

void BusManager::close() {
  if (impl_->thread.joinable() || !impl_->running.load()) return;
  impl_->finish_run();
  impl_->running.store(false);
}

bool BusManager::ready() const {
  if (impl_->ready_latched.load()) return true;
  // Also true when the thread is late to notice the timeout (or never ran).
  return impl_->started_at != TimePoint{} && impl_->steady_now() - impl_->started_at >= impl_->options.ready_timeout;
}

bool BusManager::serving() const {
  // Alive, not "every interface open": a bus waiting for its adapter must not
  // stop the watchdog, or systemd would restart the daemon and take the other
  // buses down with it. The loop turns at least every kMaxPollWait.
  const Clock::time_point last{Clock::duration{impl_->loop_alive.load(std::memory_order_relaxed)}};
  return impl_->running.load() && impl_->steady_now() - last < 3 * kMaxPollWait;
}

BusStatus BusManager::status() const {
  BusStatus s;
  {
    const std::lock_guard lock(impl_->mutex);
    s = impl_->published;
  }
  s.open = impl_->open_flag.load();
  if (const CaptureWriter* c = impl_->options.captures) {
    const can::FrameRecorder& r = c->recorder();
    s.recorder = RecorderStatus{true,
                                static_cast<std::uint32_t>(std::chrono::duration_cast<std::chrono::seconds>(c->options().before).count()),
                                r.capacity(), r.memory_bytes(), r.recorded(),
                                c->pending(), c->options().dir.string(), c->recent(),
                                c->options().budget_per_hour, c->skipped_over_budget()};
  }
  if (impl_->channel) {
    const auto st = impl_->channel->stats();
    s.rx_frames = st.rx_frames;
    s.tx_frames = st.tx_frames;
    s.rx_overflow_drops = st.rx_overflow_drops;
    s.tx_dropped = st.tx_dropped;
    s.error_frames = st.error_frames;
    s.reopens = static_cast<std::uint32_t>(st.reopens);
  }
  return s;
}

void BusManager::request_commission() {
  {
    const std::lock_guard lock(impl_->mutex);
    impl_->commission_requested = true;
  }
  impl_->wake();
}

void BusManager::acknowledge_contested(std::string device, std::string caller) {
  {
    const std::lock_guard lock(impl_->mutex);
    if (impl_->pending_acks.size() < kMaxQueuedCommands) impl_->pending_acks.emplace_back(std::move(device), std::move(caller));
  }
  impl_->wake();
}

CommandStatus BusManager::submit(DeviceCommand command) {
  {
    const std::lock_guard lock(impl_->mutex);
    if (impl_->pending_commands.size() >= kMaxQueuedCommands) return CommandStatus::busy;
    impl_->pending_commands.push_back(std::move(command));
  }
  impl_->wake();
  return CommandStatus::ok;
}

Error BusManager::submit_service(ServiceRequest command, std::shared_ptr<ServiceReplies> reply_to) {
  {
    const std::lock_guard lock(impl_->mutex);
    if (!impl_->running.load()) return Error(Errc::kUnavailable, "the bus does not run");
    if (impl_->pending_services.size() + impl_->services_waiting.load(std::memory_order_relaxed) >= kMaxServiceRequests)
      return Error(Errc::kUnavailable, "too many client commands waiting on this bus; try again");
    impl_->pending_services.emplace_back(std::move(command), std::move(reply_to));
  }
  impl_->wake();
  return {};
}

void BusManager::reload(const config::Config& config) {
  {
    const std::lock_guard lock(impl_->mutex);
    impl_->pending_reload = config;
  }
  if (impl_->options.registry != nullptr) impl_->options.registry->update_access(config.services);
  impl_->wake();
}

}  // namespace cobridge::bus
