#include "gateway/bus_manager.hpp"

#include "can/bus_event.hpp"
#include "can/socketcan_channel.hpp"
#include "canopen/cob_id.hpp"
#include "canopen/nmt.hpp"
#include "canopen/sdo_client.hpp"
#include "canopen/sync.hpp"
#include "device/family_profile.hpp"
#include "gateway/config_plan.hpp"
#include "gateway/discovery.hpp"
#include "gateway/identity_reader.hpp"
#include "gateway/log_budget.hpp"
#include "gateway/plan_runner.hpp"
#include "gateway/remote/remote_executor.hpp"
#include "gateway/remote/remote_target.hpp"
#include "gateway/supervisor.hpp"
#include "sys/logging.hpp"

#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <condition_variable>
#include <deque>
#include <optional>
#include <thread>

namespace cobridge::gateway {

namespace {

using canopen::kNever;
using canopen::TimePoint;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

constexpr std::size_t kMaxSteps = 64;            // StepTiming entries kept in the status
constexpr std::size_t kMaxProblems = 32;         // problems kept in the status
constexpr std::size_t kMaxConcurrentPlans = 2;   // plan runners at once per bus
constexpr std::size_t kMaxReceiveBatches = 16;   // per loop turn, so timers still run under load
constexpr unsigned kConfigureAttempts = 3;       // plan runs before the device is `failed`
constexpr milliseconds kConfigureRetryDelay{500};
constexpr milliseconds kFailedRetryPeriod{30000};  // a failed device is tried again this often
constexpr milliseconds kMaxPollWait{1000};
constexpr milliseconds kRebootFallbackDelay{500};
constexpr std::size_t kMaxQueuedCommands = 16;    // per bus, waiting for the control thread
constexpr std::size_t kMaxRemoteCommands = 256;   // client commands per bus, queued or waiting for their node
// After a command that passed through pre-operational, a heartbeat sent
// before the device got NMT start may still arrive: not a surprise reset.
constexpr milliseconds kCommandSettle{500};
// A re-plugged adapter is opened at most this long after it appears, so
// its devices are configured again within 2 s of its return.
constexpr milliseconds kReopenBackoffMax{500};

WallTime wall_now() { return std::chrono::system_clock::now(); }

std::string hex32(std::uint32_t v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%X", v);
  return buf;
}

}  // namespace

struct BusManager::Impl final : RemoteGate {
  // One configured device of this bus (or an unknown one discovery reported).
  struct Managed {
    config::Device cfg;
    bool in_config = true;  // false: an unknown device, shown in the status only
    DeviceStatus st;
    const device::DeviceDescription* description = nullptr;
    std::optional<device::FamilyProfile> profile;
    Supervision supervision;
    std::optional<ConfigPlan> plan;
    std::unique_ptr<canopen::SdoClient> sdo;  // the runner's; re-addressed per run
    std::unique_ptr<PlanRunner> runner;
    std::optional<DeviceCommand> command;  // the runner runs this command, not the configuration
    TimePoint preop_expected_until{};      // see kCommandSettle
    bool quick = false;       // the running plan is the fingerprint check
    bool force_full = false;  // the next run is the full plan
    bool want_configure = false;  // waiting for a runner slot
    bool started = false;         // NMT start sent after a successful plan
    bool failed_unanswered = false;  // the last failure was a silence (timeout, nothing sent)
    bool operator_hold = false;      // stopped / pre-operational by a client's NMT command: left so
    unsigned attempts = 0;
    TimePoint not_before{};       // retry back-off
    TimePoint configure_started{};
    TimePoint boot_up_at = kNever;  // last boot-up, to report how long the way back took
    LogBudget emcy_log;             // EMCY log lines (the outputs get every EMCY)
    // Buses without discovery: the identity check before configuring.
    std::unique_ptr<IdentityReader> ident;
    bool ident_wanted = false;
    bool ident_boot_up = false;
    TimePoint ident_at{};
  };

  Impl(const config::Config& config_in, std::size_t index, const device::DeviceCatalog& catalog_in,
       StateStore& state_in, BusManagerOptions options_in)
      : config(config_in), bus_index(index), catalog(catalog_in), state(state_in), options(options_in) {
    bus = config.buses.at(bus_index);
    log = sys::logger("gateway");
    build_devices();
    wake_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  }

  // ---- set-up (constructor / reload) -------------------------------------

  void build_devices() {
    devices.clear();
    for (const auto& d : config.devices) {
      if (d.bus_index != bus_index) continue;
      Managed m;
      m.cfg = d;
      m.st.name = d.name;
      m.st.bus = bus.name;
      m.st.node_id = d.node_id.value_or(0);
      m.st.identity.serial = d.serial;
      m.st.identity.vendor = d.vendor.value_or(0);
      m.st.identity.product = d.product.value_or(0);
      m.st.model = d.model;
      m.st.since = wall_now();
      devices.push_back(std::move(m));
    }
  }

  Managed* find_device(std::string_view name) {
    for (auto& m : devices) {
      if (m.st.name == name) return &m;
    }
    return nullptr;
  }
  // Any configured device at `node`, also one not seen yet.
  Managed* find_configured_node(std::uint8_t node) {
    for (auto& m : devices) {
      if (m.in_config && m.st.node_id == node) return &m;
    }
    return nullptr;
  }
  Managed* find_node(std::uint8_t node) {
    if (node == 0) return nullptr;
    for (auto& m : devices) {
      if (m.in_config && m.st.node_id == node && m.st.state != DeviceState::expected) return &m;
    }
    return nullptr;
  }

  // ---- thread ------------------------------------------------------------

  // The wake fd lives as long as the Impl: a submit() or reload() racing
  // with stop() then writes into a live eventfd, never into a closed (and
  // possibly reused) descriptor.
  ~Impl() {
    if (wake_fd >= 0) ::close(wake_fd);
  }

  std::error_code start() {
    if (wake_fd < 0) return std::make_error_code(std::errc::too_many_files_open);
    can::SocketCanConfig cc;
    cc.interface = bus.interface;
    cc.wait_for_interface = true;  // a missing adapter is reported and waited for
    cc.reopen_backoff_max = kReopenBackoffMax;
    channel = std::make_unique<can::SocketCanChannel>(cc);
    const auto err = channel->open();
    if (err) {
      log->error("bus {}: {}", bus.name, err.message);
      channel.reset();
      return err.code;
    }
    // What the control plane needs; the TPDOs go to the hot path's own socket.
    static constexpr std::array<can::Filter, 4> kFilters{{
        {canopen::cob::kSdoTxBase, 0x780, false},            // SDO responses 0x580..0x5FF
        can::Filter::exact(canopen::cob::kLssSlaveToMaster),  // LSS 0x7E4
        {canopen::cob::kNmtErrorControlBase, 0x780, false},   // boot-up/heartbeat/guarding 0x700..0x77F
        {canopen::cob::kEmcyBase, 0x780, false},              // EMCY 0x081..0x0FF
    }};
    const auto ferr = channel->set_filters(kFilters);
    if (ferr) {
      log->error("bus {}: {}", bus.name, ferr.message);
      channel.reset();
      return ferr.code;
    }
    started_at = Clock::now();
    publish_all();
    stop_requested.store(false);
    running.store(true);
    thread = std::thread([this] { run(); });
    return {};
  }

  void stop() {
    if (!thread.joinable()) return;
    stop_requested.store(true);
    wake();
    thread.join();
    running.store(false);
  }

  void wake() noexcept {
    if (wake_fd < 0) return;
    const std::uint64_t one = 1;
    [[maybe_unused]] const auto n = ::write(wake_fd, &one, sizeof one);
  }

  void run() {
    const TimePoint now0 = Clock::now();
    DiscoveryOptions dopt;
    discovery = std::make_unique<Discovery>(*channel, config, bus_index, state.on_bus(bus.name), dopt);
    remote = std::make_unique<RemoteExecutor>(*channel, bus.name, milliseconds(bus.lss_timeout_ms));
    if (bus.sync_period_ms > 0) {
      canopen::SyncProducer::Config sc;
      sc.period = milliseconds(bus.sync_period_ms);
      sc.overflow = bus.sync_counter;
      if (const auto ec = sync.configure(sc)) {
        log->error("bus {}: SYNC not produced: {}", bus.name, ec.message());
      } else {
        sync.start(now0);
      }
    }
    log->info("bus {}: serving {} ({} configured devices)", bus.name, bus.interface, devices.size());

    std::array<can::Frame, can::SocketCanChannel::kBatch> frames{};
    while (!stop_requested.load(std::memory_order_relaxed)) {
      TimePoint now = Clock::now();
      take_commands(now);

      for (std::size_t batch = 0; batch < kMaxReceiveBatches; ++batch) {
        const std::size_t n = channel->receive(frames);
        for (std::size_t i = 0; i < n; ++i) dispatch(frames[i], now);
        handle_bus_events(now);
        if (n < frames.size()) break;
      }
      handle_bus_events(now);
      if (!discovery_started && channel->is_open()) {
        // Not before: probes sent to a missing interface would mark every
        // device absent.
        discovery->start(now);
        discovery_started = true;
        check_configured_nodes(now);
      }
      loop_alive.store(now.time_since_epoch().count(), std::memory_order_relaxed);

      TimePoint next = run_components(now);
      // Handling the components' output may have started new work (a plan,
      // a reconfiguration): give it a turn at once rather than a poll later.
      while (handle_outputs(now)) {
        now = Clock::now();
        next = run_components(now);
      }
      update_ready(now);
      publish_if_dirty();

      wait(next);
    }
    sync.stop();
    runners_abort();
    remote->abort_all("the bus stopped");
    channel->close();
    open_flag.store(false);
    log->info("bus {}: stopped", bus.name);
  }

  void wait(TimePoint next) {
    const TimePoint now = Clock::now();
    milliseconds timeout = kMaxPollWait;
    if (next != kNever) {
      const auto until = std::chrono::ceil<milliseconds>(next - now);
      timeout = std::clamp(until, milliseconds(0), kMaxPollWait);
    }
    std::array<pollfd, 2> fds{};
    fds[0].fd = wake_fd;
    fds[0].events = POLLIN;
    nfds_t count = 1;
    if (channel->fd() >= 0) {
      fds[1].fd = channel->fd();
      fds[1].events = POLLIN;
      count = 2;
    }
    const int r = ::poll(fds.data(), count, static_cast<int>(timeout.count()));
    if (r > 0 && (fds[0].revents & POLLIN) != 0) {
      std::uint64_t v = 0;
      [[maybe_unused]] const auto n = ::read(wake_fd, &v, sizeof v);
    }
  }

  // ---- frames and components ----------------------------------------------

  void dispatch(const can::Frame& frame, TimePoint now) {
    // While a client's LSS command runs, its answers are not discovery's.
    if (frame.id != canopen::cob::kLssSlaveToMaster || !remote->lss_session(now)) discovery->on_frame(frame, now);
    remote->on_frame(frame, now);
    supervisor.on_frame(frame, now);
    for (auto& m : devices) {
      if (m.runner) m.runner->on_frame(frame, now);
      if (m.ident) m.ident->on_frame(frame, now);
    }
  }

  TimePoint run_components(TimePoint now) {
    TimePoint next = kNever;
    next = std::min(next, channel->process(now));
    open_flag.store(channel->is_open());
    if (!remote->lss_session(now)) next = std::min(next, discovery->process(now));
    next = std::min(next, remote->process(now, *this));
    remote_waiting.store(remote->waiting(), std::memory_order_relaxed);
    next = std::min(next, supervisor.process(now, *channel));
    next = std::min(next, sync.process(now, *channel));
    for (auto& m : devices) {
      if (m.runner) next = std::min(next, m.runner->process(now));
      if (m.want_configure && !m.runner) next = std::min(next, std::max(m.not_before, now));
      next = std::min(next, m.emcy_log.report_due());
      if (m.ident) next = std::min(next, m.ident->process(now));
      if (m.ident_wanted && !m.ident) next = std::min(next, std::max(m.ident_at, now));
    }
    return next;
  }

  // Returns true when something was done that deserves another turn at once.
  bool handle_outputs(TimePoint now) {
    bool more = false;
    for (auto& e : discovery->take_events()) {
      on_discovery_event(e, now);
      more = true;
    }
    for (auto& t : discovery->take_timings()) {
      if (t.exchanges != 0)
        log->info("bus {}: {}{}{}: {:.0f} ms, {} LSS exchanges, {} timeouts", bus.name, t.step,
                  t.device.empty() ? "" : " ", t.device, t.milliseconds, t.exchanges, t.timeouts);
      add_step(std::move(t));
    }
    for (const auto& c : supervisor.take_changes()) {
      on_supervisor_change(c, now);
      more = true;
    }
    for (auto& m : devices) {
      if (m.runner && m.runner->finished()) {
        if (m.command) {
          finish_command(m, now);
        } else {
          finish_configuration(m, now);
        }
        more = true;
      }
    }
    for (auto& m : devices) {
      if (m.ident && m.ident->finished()) {
        finish_identity(m, now);
        more = true;
      }
    }
    start_identity_reads(now);
    if (start_configurations(now)) more = true;
    report_suppressed_emcy(now);
    return more;
  }

  void handle_bus_events(TimePoint now) {
    for (const auto& ev : channel->take_events()) {
      const std::string text(can::to_string(ev.kind));
      const bool good_news = ev.kind == can::BusEventKind::InterfaceReopened ||
                             ev.kind == can::BusEventKind::ErrorActive || ev.kind == can::BusEventKind::Restarted;
      if (good_news) {
        log->info("bus {}: {}", bus.name, text);
      } else {
        log->warn("bus {}: {}", bus.name, text);
      }
      live_bus_event = text;
      dirty = true;
      if (ev.kind == can::BusEventKind::InterfaceDown) {
        for (auto& m : devices) {
          if (m.ident) {
            m.ident.reset();  // asked again when the interface is back
            m.ident_wanted = false;
          }
          if (m.runner && m.command) {
            drop_runner(m, "the CAN interface went down");
          } else if (m.runner) {
            // The transfers cannot finish; the plan runs again once the bus is back.
            m.runner.reset();
            m.want_configure = true;
            m.not_before = now;
          }
        }
      } else if (ev.kind == can::BusEventKind::InterfaceReopened) {
        on_interface_back(now);
      }
    }
  }

  // Devices may have rebooted unseen while the interface was away (their
  // boot-up went nowhere; a factory-fresh one has no heartbeat to tell us):
  // every device that was identified is checked at once (the quick plan reads
  // its key objects; a device that lost its settings gets the full plan), and
  // discovery probes the configured nodes again for those never identified.
  void on_interface_back(TimePoint now) {
    ++reopens_seen;
    for (auto& m : devices) {
      if (!m.in_config || m.st.node_id == 0) continue;
      discovery->set_supervised(m.st.node_id, false);
      if (m.description == nullptr || m.runner || m.command) continue;
      m.started = false;
      m.want_configure = true;
      m.attempts = 0;
      m.not_before = now;
      supervisor.listen(m.st.node_id, m.profile->family);
    }
    log->info("bus {}: interface back; checking every known device", bus.name);
    check_configured_nodes(now);
  }

  // ---- buses without discovery ---------------------------------------------
  // With `discovery = false` nothing probes the bus, yet the configured
  // devices at their configured node-IDs are configured, at start and after
  // every boot-up. Their identity (0x1018) is read by SDO first, so that a
  // device of another serial or model there is reported, never configured.

  void check_configured_nodes(TimePoint now) {
    if (bus.discovery) return;
    for (auto& m : devices) {
      if (!m.in_config || m.st.node_id == 0 || m.runner) continue;
      if (m.description == nullptr) supervisor.listen(m.st.node_id, canopen::DeviceFamily::generic);
      request_identity(m, now, false);
    }
  }

  void request_identity(Managed& m, TimePoint when, bool boot_up) {
    m.ident_wanted = true;
    m.ident_boot_up = m.ident_boot_up || boot_up;
    m.ident_at = when;
  }

  void start_identity_reads(TimePoint now) {
    if (!channel->is_open()) return;
    for (auto& m : devices) {
      if (!m.ident_wanted || m.ident || m.runner || now < m.ident_at) continue;
      if (m.st.node_id == remote->sdo_node()) continue;  // a client's transfer runs on it
      m.ident_wanted = false;
      m.ident = std::make_unique<IdentityReader>(sdo_of(m));
      if (m.ident->start(now)) {
        m.ident.reset();
        request_identity(m, now + kConfigureRetryDelay, false);
      }
    }
  }

  void finish_identity(Managed& m, TimePoint now) {
    const std::unique_ptr<IdentityReader> reader = std::move(m.ident);
    const bool boot_up = std::exchange(m.ident_boot_up, false);
    const auto retry = now + std::chrono::seconds(bus.discovery_period_s);
    if (!reader->identity()) {
      m.st.last_error = "no answer at node " + std::to_string(m.st.node_id) + " (0x1018: " +
                        reader->error().message() + "); discovery is off, asking again in " +
                        std::to_string(bus.discovery_period_s) + " s";
      dirty = true;
      request_identity(m, retry, false);
      return;
    }
    const canopen::LssAddress& id = *reader->identity();
    if (m.cfg.serial != 0 && id.serial != m.cfg.serial) {
      m.st.last_error = "node " + std::to_string(m.st.node_id) + " holds serial " + std::to_string(id.serial) +
                        ", not the configured " + std::to_string(m.cfg.serial) + "; not configured";
      log->warn("bus {}: device {}: {}", bus.name, m.st.name, m.st.last_error);
      add_problem("device " + m.st.name + ": " + m.st.last_error, m.st.name);
      set_state(m, DeviceState::failed);
      request_identity(m, retry, false);
      return;
    }
    DiscoveryEvent e;
    e.kind = DiscoveryEventKind::identified;
    e.node_id = e.target_node_id = m.st.node_id;
    e.at_target = true;
    e.boot_up = boot_up;
    e.identity = id;
    e.device = m.st.name;
    on_identified(e, now);
  }

  // A device that is offline (or failed for want of answers) but sends
  // frames again is checked and configured: it may have restarted unseen.
  void on_sign_of_life(Managed& m, TimePoint now) {
    const bool lost = m.st.state == DeviceState::offline ||
                      (m.st.state == DeviceState::failed && m.failed_unanswered);
    if (!lost || m.description == nullptr || m.runner || m.want_configure) return;
    log->info("bus {}: device {} (node {}) sends again while {}; checking its configuration", bus.name, m.st.name,
              m.st.node_id, to_string(m.st.state));
    m.started = false;
    m.want_configure = true;
    m.attempts = 0;
    m.not_before = now;
  }

  // ---- discovery -----------------------------------------------------------

  void on_discovery_event(const DiscoveryEvent& e, TimePoint now) {
    switch (e.kind) {
      case DiscoveryEventKind::identified:
        on_identified(e, now);
        break;
      case DiscoveryEventKind::commissioned: {
        log->info("bus {}: {}", bus.name, e.text);
        if (const auto ec = record_assignment(state, bus.name, e))
          log->error("bus {}: state file: {}", bus.name, ec.message());
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
      case DiscoveryEventKind::clash_resolved:
        log->info("bus {}: {}", bus.name, e.text);
        clear_problems([&](const Problem& p) { return p.clash_node == e.node_id; });
        break;
    }
  }

  void on_identified(const DiscoveryEvent& e, TimePoint now) {
    const std::string& name = !e.device.empty() ? e.device : e.replaces;
    Managed* m = name.empty() ? nullptr : find_device(name);
    if (m == nullptr) {
      note_unknown(e);
      return;
    }
    if (!e.replaces.empty() && m->st.identity.serial != e.identity.serial) {
      log->info("bus {}: device serial {} takes the place of {} (serial {})", bus.name, e.identity.serial,
                e.replaces, e.replaced.serial);
    }
    // A device first reported as unknown (before the swap was decided) is
    // now a configured one: drop its "unknown-" entry.
    for (const auto& u : devices) {
      if (!u.in_config && u.st.identity.serial == e.identity.serial && u.st.identity.vendor == e.identity.vendor &&
          options.observer != nullptr)
        options.observer->on_device_removed(u.st);
    }
    const auto dropped = std::erase_if(devices, [&](const Managed& u) {
      return !u.in_config && u.st.identity.serial == e.identity.serial && u.st.identity.vendor == e.identity.vendor;
    });
    if (dropped != 0) {
      dirty = true;
      m = find_device(name);  // the erase moved the elements
    }
    if (!e.at_target) {
      // Discovery is moving it; it reports `identified` again at the target.
      set_state(*m, DeviceState::commissioning);
      m->st.identity = e.identity;
      return;
    }
    const bool same_device = m->st.identity.serial == e.identity.serial && m->st.identity.vendor == e.identity.vendor;
    const bool running_fine = m->started && m->st.online && m->st.node_id == e.node_id && same_device &&
                              !e.boot_up && m->st.state == DeviceState::operational;
    if (running_fine) {
      discovery->set_supervised(e.node_id, true);
      return;
    }
    if (same_device && m->st.node_id == e.node_id && m->description != nullptr && (m->runner || m->want_configure)) {
      // Already on its way (the reboot fallback below got there first).
      if (!m->runner) m->not_before = now;
      return;
    }

    m->st.identity = e.identity;
    m->st.node_id = e.node_id;
    // Remember where it is even before it is configured (a restart then
    // needs no scan); a replacement also drops the replaced device's line.
    if (const auto ec = record_assignment(state, bus.name, e))
      log->error("bus {}: state file: {}", bus.name, ec.message());
    if (!resolve_description(*m)) {
      set_state(*m, DeviceState::failed);
      return;
    }
    supervisor.listen(e.node_id, m->profile->family);
    discovery->set_supervised(e.node_id, true);
    set_state(*m, DeviceState::identified);
    drop_runner(*m, "the device was identified anew");
    m->started = false;
    m->want_configure = true;
    m->attempts = 0;
    m->not_before = now;
  }

  void note_unknown(const DiscoveryEvent& e) {
    for (auto& m : devices) {
      if (!m.in_config && m.st.identity.serial == e.identity.serial && m.st.identity.vendor == e.identity.vendor) {
        m.st.node_id = e.node_id;
        dirty = true;
        return;
      }
    }
    Managed m;
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

  bool resolve_description(Managed& m) {
    const auto& id = m.st.identity;
    std::string variant;
    if (m.cfg.channels) variant = *m.cfg.channels == 2 ? "2ch" : "1ch";
    const device::DeviceDescription* d = nullptr;
    if (!m.cfg.eds.empty()) {
      for (const auto* c : catalog.all()) {
        if (std::filesystem::path(c->source) == m.cfg.eds) d = c;
      }
    }
    if (d == nullptr) d = catalog.select(id.vendor, id.product, id.revision, variant);
    if (d == nullptr && variant.empty()) {
      // Several variants: take the first candidate; its plan decides by what it finds.
      const auto c = catalog.candidates(id.vendor, id.product, id.revision);
      if (!c.empty()) d = c.front();
    }
    if (d == nullptr) {
      m.st.last_error = "no device description for vendor " + hex32(id.vendor) + " product " + hex32(id.product) +
                        " revision " + hex32(id.revision);
      log->error("bus {}: device {}: {}", bus.name, m.st.name, m.st.last_error);
      add_problem("device " + m.st.name + ": " + m.st.last_error, m.st.name);
      return false;
    }
    auto profile = device::family_profile_for(*d);
    if (!profile) {
      m.st.last_error = "description " + d->source + " names no known family";
      add_problem("device " + m.st.name + ": " + m.st.last_error, m.st.name);
      return false;
    }
    m.description = d;
    m.profile = profile;
    m.st.model = d->device_info.product_name;
    m.st.family = d->selection.family;
    return true;
  }

  // ---- configuration ---------------------------------------------------------

  bool start_configurations(TimePoint now) {
    if (discovery->commissioning()) return false;  // LSS/NMT resets under way: no SDO now
    // Attempts made on a closed interface would only count towards `failed`.
    if (!channel->is_open()) return false;
    std::size_t active = 0;
    for (const auto& m : devices) active += m.runner ? 1U : 0U;
    bool started_any = false;
    for (auto& m : devices) {
      if (active >= kMaxConcurrentPlans) break;
      if (!m.want_configure || m.runner || m.ident || now < m.not_before) continue;
      if (m.st.node_id == remote->sdo_node()) continue;  // a client's transfer runs on it: next turn
      m.want_configure = false;
      if (begin_configuration(m, now)) {
        ++active;
        started_any = true;
      }
    }
    return started_any;
  }

  [[nodiscard]] PlanRunnerOptions runner_options() const {
    PlanRunnerOptions ro;
    ro.sdo_retries = bus.sdo_retries;
    return ro;
  }

  // A runner for a plan on `m` (configuration or command), with the device's
  // SDO client, made on first use.
  std::unique_ptr<PlanRunner> make_runner(Managed& m, ConfigPlan plan, const PlanRunnerOptions& ro) {
    return std::make_unique<PlanRunner>(*channel, sdo_of(m), std::move(plan), ro);
  }

  // The device's SDO client, made on first use and re-addressed to its node-ID.
  canopen::SdoClient& sdo_of(Managed& m) {
    if (!m.sdo) {
      canopen::SdoClientConfig sc;
      sc.timeout = milliseconds(bus.sdo_timeout_ms);
      sc.retries = 0;  // the runner repeats timed-out transfers itself
      m.sdo = std::make_unique<canopen::SdoClient>(*channel, m.st.node_id, sc);
    } else if (!m.sdo->busy()) {
      (void)m.sdo->set_node_id(m.st.node_id);
    }
    return *m.sdo;
  }

  bool begin_configuration(Managed& m, TimePoint now) {
    if (!m.plan || m.plan->node_id != m.st.node_id || m.force_full) {
      auto result = make_config_plan(m.cfg, *m.description, *m.profile, m.st.node_id);
      if (!result.ok()) {
        std::string text;
        for (const auto& err : result.errors) {
          if (!text.empty()) text += "; ";
          text += err.to_string();
        }
        m.st.last_error = text;
        log->error("bus {}: {}", bus.name, text);
        add_problem(text, m.st.name);
        set_state(m, DeviceState::failed);
        return false;
      }
      m.plan = std::move(result.plan);
    }
    m.supervision = supervision_for(m);
    PlanRunnerOptions ro = runner_options();

    // A device that carries the fingerprint of this plan (state file) only
    // gets a quick read-back of its key objects; the full plan runs when they
    // disagree (it lost or changed its configuration) or when the family
    // keeps part of the settings in volatile memory only.
    const auto previous = state.find(bus.name, m.st.identity.vendor, m.st.identity.product, m.st.identity.serial);
    const bool volatile_parts = !m.profile->cams_stored && !m.cfg.cams.empty();
    m.quick = !m.force_full && previous && previous->fingerprint == m.plan->fingerprint && !volatile_parts;
    ConfigPlan run_plan = m.quick ? quick_plan(*m.plan) : *m.plan;
    if (m.force_full && m.plan->store_policy == config::StorePolicy::on_change) {
      // The quick check already put some values back, so "changed" would
      // miss them: store everything the plan names.
      run_plan.store_policy = config::StorePolicy::always;
    }
    // The start is ours (finish_configuration): the hot path learns the
    // mapping first, so the first TPDO after the start is decoded.
    ro.start_node = false;
    m.force_full = false;
    m.runner = make_runner(m, std::move(run_plan), ro);
    m.configure_started = now;
    ++m.attempts;
    set_state(m, DeviceState::configuring);
    if (const auto ec = m.runner->start(now)) {
      log->error("bus {}: device {}: plan not started: {}", bus.name, m.st.name, ec.message());
      m.runner.reset();
      m.want_configure = true;
      m.not_before = now + kConfigureRetryDelay;
      return false;
    }
    return true;
  }

  // The objects whose agreement says "this device still carries its
  // configuration": supervision and the PDO mappings, read (and compared)
  // between pre-operational and nothing else. No store step.
  static ConfigPlan quick_plan(const ConfigPlan& full) {
    ConfigPlan q = full;
    q.steps.clear();
    for (const auto& step : full.steps) {
      const bool key_write = step.kind == StepKind::write &&
                             (step.write.index == 0x1017 || step.write.index == 0x100C || step.write.index == 0x100D);
      if (step.kind == StepKind::nmt || step.kind == StepKind::tpdo_mapping || key_write) q.steps.push_back(step);
    }
    return q;
  }

  Supervision supervision_for(const Managed& m) const {
    Supervision s;
    if (m.cfg.guarding && m.cfg.guarding->guard_time_ms > 0 && m.cfg.guarding->life_time_factor > 0) {
      s.mode = Supervision::Mode::guarding;
      s.guard_time = milliseconds(m.cfg.guarding->guard_time_ms);
      s.life_time_factor = m.cfg.guarding->life_time_factor;
    } else if (m.plan && m.plan->heartbeat && m.plan->heartbeat_ms > 0) {
      s.mode = Supervision::Mode::heartbeat;
      s.producer_time = milliseconds(m.plan->heartbeat_ms);
    } else if (m.cfg.heartbeat_ms && *m.cfg.heartbeat_ms > 0) {
      s.mode = Supervision::Mode::heartbeat;
      s.producer_time = milliseconds(*m.cfg.heartbeat_ms);
    }
    return s;
  }

  void finish_configuration(Managed& m, TimePoint now) {
    const PlanRunResult outcome = m.runner->result();
    m.runner.reset();
    const double ms = std::chrono::duration<double, std::milli>(now - m.configure_started).count();
    StepTiming t;
    t.step = (m.quick ? "verify " : "configure ") + m.st.name;
    t.device = m.st.name;
    t.milliseconds = ms;
    add_step(std::move(t));
    m.failed_unanswered = !outcome.ok() && (outcome.error == make_error_code(PlanRunErrc::sdo_timeout) ||
                                            outcome.error == make_error_code(PlanRunErrc::send_failed));
    if (!outcome.ok()) {
      m.st.last_error = outcome.message;
      log->warn("bus {}: device {}: configuration failed (attempt {}): {}", bus.name, m.st.name, m.attempts,
                outcome.message);
      m.want_configure = true;
      if (m.attempts >= kConfigureAttempts) {
        set_state(m, DeviceState::failed);
        m.not_before = now + kFailedRetryPeriod;
        m.attempts = 0;
      } else {
        set_state(m, DeviceState::identified);
        m.not_before = now + kConfigureRetryDelay;
      }
      return;
    }
    if (m.quick && outcome.writes > 0) {
      // The fingerprint matched but the device did not carry the values.
      log->info("bus {}: device {}: key objects differed from the stored configuration; full plan", bus.name,
                m.st.name);
      m.force_full = true;
      m.want_configure = true;
      m.not_before = now;
      --m.attempts;
      return;
    }
    if (outcome.writes > 0) ++m.st.configurations;
    if (outcome.guarding_fallback) {
      // The device refused 0x1017 (J§1.2.2): the plan's fallback guards it.
      m.supervision = fallback_guarding(*m.plan);
    }
    m.st.fingerprint = m.plan->fingerprint;
    Assignment a;
    a.bus = bus.name;
    a.serial = m.st.identity.serial;
    a.vendor = m.st.identity.vendor;
    a.product = m.st.identity.product;
    a.revision = m.st.identity.revision;
    a.node_id = m.st.node_id;
    a.fingerprint = m.plan->fingerprint;
    if (const auto ec = state.put(a)) log->error("bus {}: state file: {}", bus.name, ec.message());
    if (!announce_and_start(m, now)) return;

    // Started: operational from here, and supervised from now on.
    m.started = true;
    m.attempts = 0;
    m.st.last_error.clear();
    m.st.nmt = canopen::NmtState::operational;
    supervisor.watch(m.st.node_id, m.profile->family, m.supervision, now);
    m.st.online = m.supervision.mode == Supervision::Mode::none;
    set_state(m, DeviceState::operational);
    clear_problems([&](const Problem& p) { return p.device == m.st.name; });
    if (m.boot_up_at != kNever) {
      const double back = std::chrono::duration<double, std::milli>(now - m.boot_up_at).count();
      log->info("bus {}: device {} back in operation {:.0f} ms after its boot-up ({} writes, {} saves)", bus.name,
                m.st.name, back, outcome.writes, outcome.saves);
      StepTiming bt;
      bt.step = "back after boot-up";
      bt.device = m.st.name;
      bt.milliseconds = back;
      add_step(std::move(bt));
      m.boot_up_at = kNever;
    } else {
      log->info("bus {}: device {} operational at node {} ({:.0f} ms, {} writes, {} saves)", bus.name, m.st.name,
                m.st.node_id, ms, outcome.writes, outcome.saves);
    }
  }

  // Plans leave the NMT start to us, so that a device found different by
  // the quick check is not started half configured, and so that the hot path
  // has the device's mapping before its first TPDO (issue 10, item 4).
  bool announce_and_start(Managed& m, TimePoint now) {
    if (options.observer != nullptr) {
      std::vector<std::uint32_t> tpdo1, tpdo2;
      for (const auto& step : m.plan->steps) {
        if (step.kind != StepKind::tpdo_mapping) continue;
        if (step.tpdo == 1) tpdo1 = step.mapping;
        if (step.tpdo == 2) tpdo2 = step.mapping;
      }
      DeviceStatus announced = m.st;
      announced.state = DeviceState::operational;
      announced.nmt = canopen::NmtState::operational;
      options.observer->on_device_configured(announced, tpdo1, tpdo2);
    }
    if (channel->send(canopen::make_nmt(canopen::NmtCommand::start, m.st.node_id))) return true;
    m.st.last_error = "NMT start could not be sent";
    m.want_configure = true;
    m.not_before = now + kConfigureRetryDelay;
    return false;
  }

  static Supervision fallback_guarding(const ConfigPlan& plan) {
    Supervision s;
    s.mode = Supervision::Mode::guarding;
    for (const auto& step : plan.steps) {
      for (const auto& w : step.fallback) {
        if (w.index == 0x100C) s.guard_time = milliseconds(w.value);
        if (w.index == 0x100D) s.life_time_factor = static_cast<std::uint8_t>(w.value);
      }
    }
    if (s.guard_time.count() == 0 || s.life_time_factor == 0) s.mode = Supervision::Mode::none;
    return s;
  }

  void runners_abort() {
    for (auto& m : devices) drop_runner(m, "the gateway is stopping");
  }

  // Ends whatever the runner does; a command's submitter learns why.
  void drop_runner(Managed& m, const char* why) {
    if (m.command && m.runner && m.runner->finished()) {
      // Done before what ends it was seen (an NMT reset's own boot-up can
      // arrive in the same loop turn): the command's outcome stands.
      finish_command(m, Clock::now());
      return;
    }
    m.runner.reset();
    if (!m.command) return;
    DeviceCommand cmd = std::move(*m.command);
    m.command.reset();
    report_command(m, cmd, CommandOutcome{CommandStatus::failed, 0, std::string("aborted: ") + why});
  }

  // ---- commands from plugins ---------------------------------------------------

  void report_command(const Managed& m, const DeviceCommand& cmd, const CommandOutcome& outcome) {
    if (outcome.status == CommandStatus::ok) {
      log->info("bus {}: device {}: {} done", bus.name, m.st.name, to_string(cmd.kind));
    } else {
      log->warn("bus {}: device {}: {}: {}{}{}", bus.name, m.st.name, to_string(cmd.kind), to_string(outcome.status),
                outcome.message.empty() ? "" : ": ", outcome.message);
    }
    if (options.observer != nullptr) options.observer->on_command_done(m.st, cmd, outcome);
  }

  void start_command(DeviceCommand cmd, TimePoint now) {
    Managed* m = find_device(cmd.device);
    if (m == nullptr || !m->in_config) {
      Managed none;
      none.st.name = cmd.device;
      none.st.bus = bus.name;
      report_command(none, cmd, CommandOutcome{CommandStatus::unknown_device, 0, "not configured on this bus"});
      return;
    }
    if (m->runner || m->st.node_id == remote->sdo_node()) {
      report_command(*m, cmd,
                     CommandOutcome{CommandStatus::busy, 0, m->command ? "another command runs" : "being configured"});
      return;
    }
    if (m->st.state != DeviceState::operational || m->description == nullptr || !m->profile || m->st.node_id == 0) {
      report_command(*m, cmd,
                     CommandOutcome{CommandStatus::offline, 0, std::string("device is ") + to_string(m->st.state)});
      return;
    }
    auto plan = make_command_plan(m->st.name, *m->description, *m->profile, m->st.node_id, cmd.kind, cmd.value);
    if (!plan.ok()) {
      std::string text;
      bool range = false;
      for (const auto& err : plan.errors) {
        if (!text.empty()) text += "; ";
        text += err.to_string();
        range = range || err.out_of_range;
      }
      report_command(*m, cmd,
                     CommandOutcome{range ? CommandStatus::invalid_value : CommandStatus::unsupported, 0, text});
      return;
    }
    log->info("bus {}: device {}: {}{} requested by an output", bus.name, m->st.name, to_string(cmd.kind),
              cmd.kind == CommandKind::preset ? " to " + std::to_string(cmd.value) : std::string());
    m->command = std::move(cmd);
    m->runner = make_runner(*m, std::move(*plan.plan), runner_options());
    if (const auto ec = m->runner->start(now)) drop_runner(*m, ec.message().c_str());
  }

  void finish_command(Managed& m, TimePoint now) {
    const PlanRunResult r = m.runner->result();
    m.runner.reset();
    DeviceCommand cmd = std::move(*m.command);
    m.command.reset();
    if (cmd.kind == CommandKind::store) m.preop_expected_until = now + kCommandSettle;
    CommandOutcome out;
    out.message = r.message;
    if (r.ok()) {
      out.status = CommandStatus::ok;
    } else if (r.error == make_error_code(PlanRunErrc::sdo_abort)) {
      out.status = CommandStatus::refused;
      out.abort_code = static_cast<std::uint32_t>(r.sdo_error.value());
    } else if (r.error == make_error_code(PlanRunErrc::sdo_timeout)) {
      out.status = CommandStatus::timeout;
    } else if (r.error == make_error_code(PlanRunErrc::sdo_busy)) {
      out.status = CommandStatus::busy;
    } else {
      out.status = CommandStatus::failed;
    }
    report_command(m, cmd, out);
  }

  // ---- supervision -------------------------------------------------------------

  void on_supervisor_change(const Supervisor::Change& c, TimePoint now) {
    Managed* m = find_node(c.node);
    if (m == nullptr && !bus.discovery && c.kind == Supervisor::ChangeKind::rebooted) m = find_configured_node(c.node);
    if (m == nullptr) return;
    apply(c, m->st, wall_now());
    dirty = true;
    notify(*m);
    switch (c.kind) {
      case Supervisor::ChangeKind::rebooted:
        log->info("bus {}: device {} (node {}) rebooted", bus.name, m->st.name, c.node);
        // Discovery re-identifies it after every boot-up (same serial, or a
        // replacement part); its `identified` event restarts the plan.
        m->boot_up_at = now;
        m->started = false;
        m->operator_hold = false;  // a restarted device is started again, whoever stopped it before
        drop_runner(*m, "the device rebooted");
        m->ident.reset();
        // Should discovery's re-identification not come, configure it anyway
        // (same node-ID, the identity it had) after a while.
        m->want_configure = m->description != nullptr;
        m->attempts = 0;
        m->not_before = now + kRebootFallbackDelay;
        if (!bus.discovery) {
          // Nobody else re-identifies it: read its identity now.
          m->want_configure = false;
          request_identity(*m, now, true);
        }
        if (m->st.state != DeviceState::expected) set_state(*m, DeviceState::identified);
        break;
      case Supervisor::ChangeKind::offline:
        log->warn("bus {}: device {} (node {}) offline: {}", bus.name, m->st.name, c.node, c.reason);
        // Let discovery's periodic probe look at it: if it rebooted without a
        // boot-up we saw (interface loss), it is re-identified and configured.
        discovery->set_supervised(c.node, false);
        break;
      case Supervisor::ChangeKind::online:
        log->info("bus {}: device {} (node {}) online", bus.name, m->st.name, c.node);
        discovery->set_supervised(c.node, true);
        on_sign_of_life(*m, now);
        break;
      case Supervisor::ChangeKind::nmt_state:
        on_nmt_state(*m, c.nmt, now);
        break;
      case Supervisor::ChangeKind::emcy:
        if (emcy_log_allowed(*m, now)) log->warn("bus {}: device {} (node {}): {}", bus.name, m->st.name, c.node, c.emcy_text);
        on_sign_of_life(*m, now);
        break;
    }
  }

  // The heartbeat (or guarding reply) tells the device's NMT state (CiA 301
  // §7.2.8.3.2): the status follows it, and a device another NMT master
  // stopped or sent to pre-operational is started again (policy restart) or
  // left as that master wants it (policy respect); either way it is logged.
  void on_nmt_state(Managed& m, canopen::NmtState nmt, TimePoint now) {
    if (!m.started || m.runner || now < m.preop_expected_until) return;
    if (m.operator_hold && nmt != canopen::NmtState::operational) {
      set_state(m, DeviceState::stopped);  // a client's NMT command: left as asked
      return;
    }
    const bool restart = bus.foreign_nmt == config::ForeignNmt::restart;
    if (nmt == canopen::NmtState::operational) {
      if (m.st.state != DeviceState::stopped) return;
      log->info("bus {}: device {} (node {}) is operational again", bus.name, m.st.name, m.st.node_id);
      m.st.last_error.clear();
      set_state(m, m.st.online ? DeviceState::operational : DeviceState::offline);
      return;
    }
    if (nmt == canopen::NmtState::stopped) {
      if (m.st.state == DeviceState::stopped) return;
      m.st.last_error = "stopped by another NMT master";
      set_state(m, DeviceState::stopped);
      if (!restart) {
        log->warn("bus {}: device {} (node {}) was stopped by another NMT master; left stopped (foreign_nmt = "
                  "respect)", bus.name, m.st.name, m.st.node_id);
        return;
      }
      log->warn("bus {}: device {} (node {}) was stopped by another NMT master; starting it again", bus.name,
                m.st.name, m.st.node_id);
      if (!channel->send(canopen::make_nmt(canopen::NmtCommand::start, m.st.node_id)))
        log->error("bus {}: device {}: NMT start could not be sent", bus.name, m.st.name);
      return;
    }
    if (nmt != canopen::NmtState::pre_operational) return;
    if (!restart) {
      log->warn("bus {}: device {} (node {}) is pre-operational (another NMT master, or a reset whose boot-up was "
                "missed); left so (foreign_nmt = respect)", bus.name, m.st.name, m.st.node_id);
      m.st.last_error = "pre-operational: not started by this gateway";
      set_state(m, DeviceState::stopped);
      return;
    }
    // Someone (or a reset we missed) put it back: check, configure and start again.
    log->warn("bus {}: device {} (node {}) is pre-operational again; reconfiguring", bus.name, m.st.name,
              m.st.node_id);
    m.started = false;
    m.want_configure = true;
    m.attempts = 0;
    m.not_before = now;
    supervisor.listen(m.st.node_id, m.profile ? m.profile->family : canopen::DeviceFamily::generic);
    set_state(m, DeviceState::identified);
  }

  bool emcy_log_allowed(Managed& m, TimePoint now) { return m.emcy_log.allow(now); }

  void report_suppressed_emcy(TimePoint now) {
    for (auto& m : devices) {
      if (const std::uint32_t n = m.emcy_log.take_suppressed(now))
        log->warn("bus {}: device {} (node {}): {} more EMCY not logged (last: {}); every one reached the outputs",
                  bus.name, m.st.name, m.st.node_id, n, m.st.last_emcy_text);
    }
  }

  // ---- commands from other threads ------------------------------------------

  void take_commands(TimePoint now) {
    bool commission = false;
    std::optional<config::Config> reload_config;
    std::deque<DeviceCommand> commands;
    std::deque<std::pair<RemoteCommand, std::shared_ptr<RemoteReplies>>> clients;
    {
      const std::lock_guard lock(mutex);
      commission = std::exchange(commission_requested, false);
      reload_config = std::exchange(pending_reload, std::nullopt);
      commands.swap(pending_commands);
      clients.swap(pending_remote);
    }
    for (auto& [c, to] : clients) remote->add(std::move(c), std::move(to), now);
    if (commission) discovery->request_commission();
    if (reload_config) apply_reload(std::move(*reload_config), now);
    for (auto& c : commands) start_command(std::move(c), now);
  }

  void apply_reload(config::Config next, TimePoint now) {
    const config::Bus* nb = next.find_bus(bus.name);
    if (nb == nullptr) {
      log->warn("bus {}: not in the new configuration; kept as it is until restart", bus.name);
      return;
    }
    std::size_t new_index = 0;
    for (std::size_t i = 0; i < next.buses.size(); ++i) {
      if (next.buses[i].name == bus.name) new_index = i;
    }
    if (nb->interface != bus.interface) {
      log->warn("bus {}: a new interface ({}) needs a restart; kept {}", bus.name, nb->interface, bus.interface);
    }
    const std::string interface = bus.interface;
    config = std::move(next);
    bus_index = new_index;
    bus = config.buses[bus_index];
    bus.interface = interface;
    discovery->reload(config, bus_index, state.on_bus(bus.name));

    std::vector<Managed> old = std::move(devices);
    devices.clear();
    for (const auto& d : config.devices) {
      if (d.bus_index != bus_index) continue;
      auto it = std::find_if(old.begin(), old.end(), [&](const Managed& o) { return o.in_config && o.cfg.name == d.name; });
      if (it == old.end()) {
        Managed m;
        m.cfg = d;
        m.st.name = d.name;
        m.st.bus = bus.name;
        m.st.node_id = d.node_id.value_or(0);
        m.st.identity.serial = d.serial;
        m.st.since = wall_now();
        devices.push_back(std::move(m));
        continue;
      }
      Managed m = std::move(*it);
      old.erase(it);
      m.cfg = d;
      if (m.started && m.description != nullptr && m.profile) {
        // Reconfigure only if the settings as applied would differ.
        const auto plan = make_config_plan(m.cfg, *m.description, *m.profile, m.st.node_id);
        if (!plan.ok() || !m.plan || plan.plan->fingerprint != m.plan->fingerprint) {
          log->info("bus {}: device {}: settings changed; reconfiguring", bus.name, m.st.name);
          m.plan.reset();
          m.started = false;  // the plan puts it in pre-operational: not a surprise
          supervisor.listen(m.st.node_id, m.profile->family);
          m.want_configure = true;
          m.attempts = 0;
          m.not_before = now;
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
    dirty = true;
  }

  // ---- clients' commands (RemoteGate) ------------------------------------------

  bool node_free(std::uint8_t node) const override {
    if (discovery->commissioning() || !channel->is_open()) return false;
    for (const auto& m : devices) {
      if (node != 0 && m.st.node_id != node) continue;
      if (m.runner || m.ident || m.command) return false;
      const auto s = m.st.state;
      if (s == DeviceState::identified || s == DeviceState::configuring || s == DeviceState::commissioning) return false;
      if (m.want_configure && s != DeviceState::failed) return false;
    }
    return true;
  }

  bool node_supervised(std::uint8_t node) const override {
    return std::any_of(devices.begin(), devices.end(),
                       [&](const Managed& m) { return m.in_config && m.st.node_id == node && m.description != nullptr; });
  }

  bool lss_allowed() const override { return !discovery->commissioning() && channel->is_open(); }

  void on_nmt_sent(canopen::NmtCommand command, std::uint8_t node, const std::string& caller) override {
    const bool hold = command == canopen::NmtCommand::stop || command == canopen::NmtCommand::enter_preop;
    for (auto& m : devices) {
      if (!m.in_config || (node != 0 && m.st.node_id != node)) continue;
      m.operator_hold = hold;
      if (hold) {
        m.st.last_error = "left " + std::string(command == canopen::NmtCommand::stop ? "stopped" : "pre-operational") +
                          " by a client's NMT command (" + caller + ")";
        set_state(m, DeviceState::stopped);
      }
    }
  }

  void on_lss_node_id(const canopen::LssAddress& device, std::uint8_t node, bool stored) override {
    log->info("bus {}: a client set serial {} to node-ID {}{}", bus.name, device.serial, node,
              stored ? " (stored)" : " (not stored)");
    if (!stored) return;
    DiscoveryEvent e;
    e.kind = DiscoveryEventKind::commissioned;
    e.node_id = node;
    e.previous_node_id = canopen::cob::kNodeIdUnconfigured;
    e.identity = device;
    if (const auto ec = record_assignment(state, bus.name, e)) log->error("bus {}: state file: {}", bus.name, ec.message());
  }

  // ---- status ------------------------------------------------------------------

  void set_state(Managed& m, DeviceState s) {
    if (m.st.state == s) return;
    m.st.state = s;
    m.st.since = wall_now();
    dirty = true;
    notify(m);
  }

  void notify(const Managed& m) {
    if (options.observer != nullptr) options.observer->on_device_status(m.st);
  }

  void add_step(StepTiming t) {
    if (t.at == WallTime{}) t.at = wall_now();
    steps.push_back(std::move(t));
    if (steps.size() > kMaxSteps) steps.erase(steps.begin());
    dirty = true;
  }

  // A problem stays in the status while it is true: a device's own problems
  // leave when it is operational, a clash's when it is resolved.
  void add_problem(const std::string& text, const std::string& device = {}, std::uint8_t clash_node = 0) {
    for (const auto& p : problems) {
      if (p.text == text) return;
    }
    problems.push_back(Problem{text, device, clash_node});
    if (problems.size() > kMaxProblems) problems.erase(problems.begin());
    dirty = true;
  }

  template <typename Pred>
  void clear_problems(Pred pred) {
    if (std::erase_if(problems, pred) != 0) dirty = true;
  }

  void update_ready(TimePoint now) {
    if (ready_latched.load()) return;
    bool all = true;
    for (const auto& m : devices) {
      if (m.in_config && m.st.state != DeviceState::operational) all = false;
    }
    if (all || now - started_at >= options.ready_timeout) {
      if (!all) log->warn("bus {}: ready after {} ms with devices not operational", bus.name,
                          options.ready_timeout.count());
      ready_latched.store(true);
    }
  }

  void publish_if_dirty() {
    if (!dirty) return;
    dirty = false;
    publish_all();
  }

  void publish_all() {
    BusStatus s;
    s.name = bus.name;
    s.interface = bus.interface;
    s.last_bus_event = live_bus_event;
    s.devices.reserve(devices.size());
    for (const auto& m : devices) s.devices.push_back(m.st);
    s.steps = steps;
    for (const auto& p : problems) s.problems.push_back(p.text);
    const std::lock_guard lock(mutex);
    published = std::move(s);
  }

  // ---- members -------------------------------------------------------------------

  // Thread contract: everything below up to `mutex` belongs to the control
  // thread once start() has run.
  config::Config config;
  std::size_t bus_index;
  config::Bus bus;
  const device::DeviceCatalog& catalog;
  StateStore& state;
  BusManagerOptions options;
  std::shared_ptr<spdlog::logger> log;

  std::unique_ptr<can::SocketCanChannel> channel;
  std::unique_ptr<Discovery> discovery;
  std::unique_ptr<RemoteExecutor> remote;
  Supervisor supervisor;
  canopen::SyncProducer sync;
  std::vector<Managed> devices;
  std::vector<StepTiming> steps;
  struct Problem {
    std::string text;
    std::string device;          // the configured device it is about (empty: the bus)
    std::uint8_t clash_node = 0; // a clash at this node-ID
  };
  std::vector<Problem> problems;
  std::string live_bus_event;
  std::uint32_t reopens_seen = 0;
  bool discovery_started = false;
  bool dirty = true;
  TimePoint started_at{};

  std::thread thread;
  int wake_fd = -1;
  std::atomic<bool> stop_requested{false};
  std::atomic<bool> running{false};
  std::atomic<bool> open_flag{false};
  std::atomic<bool> ready_latched{false};
  std::atomic<Clock::rep> loop_alive{0};
  std::atomic<std::size_t> remote_waiting{0};  // client commands in the executor (kMaxRemoteCommands)  // steady_clock ticks of the last loop turn (watchdog)

  // Shared with the callers of status()/reload()/request_commission().
  mutable std::mutex mutex;
  BusStatus published;
  bool commission_requested = false;
  std::optional<config::Config> pending_reload;
  std::deque<DeviceCommand> pending_commands;
  std::deque<std::pair<RemoteCommand, std::shared_ptr<RemoteReplies>>> pending_remote;
};

BusManager::BusManager(const config::Config& config, std::size_t bus_index, const device::DeviceCatalog& catalog,
                       StateStore& state, BusManagerOptions options)
    : impl_(std::make_unique<Impl>(config, bus_index, catalog, state, options)) {}

BusManager::~BusManager() { stop(); }

std::error_code BusManager::start() {
  if (impl_->thread.joinable()) return std::make_error_code(std::errc::device_or_resource_busy);
  RemoteBus rb{impl_->bus.name, impl_->bus.interface, static_cast<unsigned>(impl_->bus_index + 1)};
  const config::RemoteAccess access = impl_->config.remote;
  if (const auto ec = impl_->start()) return ec;
  BusRegistry::process().add(*this, std::move(rb), access);
  return {};
}

void BusManager::stop() {
  BusRegistry::process().remove(*this);
  impl_->stop();
}

bool BusManager::ready() const {
  if (impl_->ready_latched.load()) return true;
  // Also true when the thread is late to notice the timeout (or never ran).
  return impl_->started_at != TimePoint{} && Clock::now() - impl_->started_at >= impl_->options.ready_timeout;
}

bool BusManager::serving() const {
  // Alive, not "every interface open": a bus waiting for its adapter must not
  // stop the watchdog, or systemd would restart the daemon and take the other
  // buses down with it. The loop turns at least every kMaxPollWait.
  const Clock::time_point last{Clock::duration{impl_->loop_alive.load(std::memory_order_relaxed)}};
  return impl_->running.load() && Clock::now() - last < 3 * kMaxPollWait;
}

BusStatus BusManager::status() const {
  BusStatus s;
  {
    const std::lock_guard lock(impl_->mutex);
    s = impl_->published;
  }
  s.open = impl_->open_flag.load();
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

CommandStatus BusManager::submit(DeviceCommand command) {
  {
    const std::lock_guard lock(impl_->mutex);
    if (impl_->pending_commands.size() >= kMaxQueuedCommands) return CommandStatus::busy;
    impl_->pending_commands.push_back(std::move(command));
  }
  impl_->wake();
  return CommandStatus::ok;
}

Error BusManager::submit_remote(RemoteCommand command, std::shared_ptr<RemoteReplies> reply_to) {
  {
    const std::lock_guard lock(impl_->mutex);
    if (!impl_->running.load()) return Error(Errc::kUnavailable, "the bus does not run");
    if (impl_->pending_remote.size() + impl_->remote_waiting.load(std::memory_order_relaxed) >= kMaxRemoteCommands)
      return Error(Errc::kUnavailable, "too many client commands waiting on this bus; try again");
    impl_->pending_remote.emplace_back(std::move(command), std::move(reply_to));
  }
  impl_->wake();
  return {};
}

void BusManager::reload(const config::Config& config) {
  {
    const std::lock_guard lock(impl_->mutex);
    impl_->pending_reload = config;
  }
  BusRegistry::process().update_access(config.remote);
  impl_->wake();
}

}  // namespace cobridge::gateway
