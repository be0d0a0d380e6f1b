// BusController: one bus's decisions on its control thread: discovery,
// commissioning, configuration plans, supervision, drift, the hot-standby
// election, timelines and the published status. It takes frames and time
// from its shell (BusManager, bus_manager.cpp: the thread, the socket, its
// poll, the clocks, netlink and the journal's thread) and returns its next
// deadline, CANopenNode's `process(now, &next)` shape:
//
//   set_time(now, wall)          the shell's clock reading for the calls after it
//   on_frame(frame, now, arrived) a frame from the bus (arrived: its kernel stamp
//                                 on the steady clock, stamp_clock.hpp)
//   on_port_events(now)          the port's bus events (link, error frames)
//   process(now, lost)           the components' turn; next deadline
//   handle_outputs(now) / settle(now)  see below
//
// It reads no clock and owns no socket or thread: it sends through the port
// it is given (can::BusPort, a FrameSink: a SocketCAN socket in the daemon,
// can::VirtualBus::Port in unit tests) and writes timelines through a
// TimelineSink. So its decisions run in unit tests on a virtual bus with
// simulated devices and a fake clock (tests/unit/bus/virtual_line.hpp).
//
// Its members are defined by concept: bus_controller.cpp (set-up, reload,
// the turn), bus_controller_frames.cpp (frames, outputs and bus events of
// the protocol components; supervision), bus_controller_discovery.cpp
// (discovery and the identity check of buses without it),
// bus_controller_configure.cpp (configuration plans and plugins' commands),
// bus_controller_service.cpp (the ServiceGate for clients' commands),
// bus_controller_drift.cpp (clients' writes of configured objects),
// bus_controller_health.cpp (the controller's health to the observer),
// bus_controller_election.cpp and _standby.cpp (the hot-standby pair),
// bus_controller_status.cpp and _timeline.cpp (status and timelines). What
// is decided from one device's own record and the time alone is the
// device's (bus/device_agent.hpp): these files act on its verdicts.
//
// Threads: everything runs on the bus's control thread except what the
// shell's public calls read from other threads: the atomics and what
// `mutex` guards (see the thread contract at the members below).
#pragma once

#include "bus/bus_manager.hpp"
#include "bus/timeline_sink.hpp"

#include "can/bus_event.hpp"
#include "can/controller_netlink.hpp"
#include "can/bus_port.hpp"
#include "canopen/cob_id.hpp"
#include "canopen/master_election.hpp"
#include "canopen/nmt.hpp"
#include "canopen/sdo_client.hpp"
#include "canopen/sdo_observer.hpp"
#include "canopen/sync.hpp"
#include "device/family_profile.hpp"
#include "bus/config_plan.hpp"
#include "bus/device_agent.hpp"
#include "bus/discovery.hpp"
#include "bus/identity_reader.hpp"
#include "bus/log_budget.hpp"
#include "bus/restore_guard.hpp"
#include "bus/plan_runner.hpp"
#include "bus/service/service_executor.hpp"
#include "bus/service/service_target.hpp"
#include "bus/standby_listener.hpp"
#include "bus/status_board.hpp"
#include "bus/supervisor.hpp"
#include "sys/logging.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <optional>

namespace cobridge::bus {

namespace {

using canopen::kNever;
using canopen::TimePoint;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

constexpr std::size_t kMaxConcurrentPlans = 2;   // plan runners at once per bus
constexpr milliseconds kRebootFallbackDelay{500};
// Frames the kernel dropped at the control socket are logged at most this
// often, summed up.
constexpr milliseconds kControlDropReportPeriod{1000};
// Role changes logged per window; more are counted and summed up in one line.
constexpr std::uint32_t kRoleLogLines = 6;
constexpr std::chrono::seconds kRoleLogWindow{60};

}  // namespace

struct BusController final : ServiceGate {
  // `journal`: where the configured devices' timeline events go (the
  // journal's writer thread in the daemon), `kept`: their events from the
  // journal of the last run; the devices' timelines start from them.
  // `now`, `wall`: the shell's clock reading (set_time).
  BusController(const config::Config& config_in, std::size_t index, const device::DeviceCatalog& catalog_in,
                StateStore& state_in, BusManagerOptions options_in, TimelineSink* journal_in,
                TimelineSink::Kept kept, TimePoint now, WallTime wall);

  // ---- the shell's calls (control thread) ----------------------------------

  // The shell's clock reading, for every call after it until the next: what
  // status and timelines stamp (wall) and what a call without a `now` of its
  // own uses (steady). Nothing here reads a clock.
  void set_time(TimePoint now, WallTime wall) noexcept {
    now_ = now;
    wall_ = wall;
  }
  // The bus to run on, before begin(); the shell owns it.
  void attach(can::BusPort& port) noexcept { channel = &port; }
  // The bus opened (status published, ready_timeout counted from `now`).
  void opened(TimePoint now);
  void start_components(TimePoint now);
  // One frame the port received; `arrived`: when it reached the socket (its
  // kernel stamp on the steady clock; `now` for a port that stamps nothing).
  void on_frame(const can::Frame& frame, TimePoint now, TimePoint arrived);
  // Whether on_frame's `arrived` matters: the election judges a gateway's
  // heartbeat by it; nothing else does, so the shell need not work it out.
  [[nodiscard]] bool judges_arrival() const noexcept { return election.has_value(); }
  // The port's bus events since the last call; true when the interface went down.
  bool on_port_events(TimePoint now) { return handle_bus_events(now); }
  // The turn's components after its frames: `lost` the interface went down
  // in this turn. Returns the next deadline; then handle_outputs(now) until
  // it is false (each true: new work started, so the shell reads its clock
  // and the port again and calls run_components), then settle(now).
  TimePoint process(TimePoint now, bool lost);
  // Readiness, the published status and the journal's hand-over, after the
  // turn's work; returns when the journal is next due.
  TimePoint settle(TimePoint now);
  // The CAN controller's state over netlink (the shell reads it once a second
  // on a kernel interface).
  void on_netlink(const Result<can::NetlinkReading>& reading);
  // After the last turn: the journal flushed, the components ended (the
  // shell closes the port after it).
  void finish_run(TimePoint now);
  // Clients' commands, handed over from other threads by the shell.
  void request_commission() { discovery->request_commission(); }
  void add_service(ServiceRequest c, std::shared_ptr<ServiceReplies> to, TimePoint now) {
    services->add(std::move(c), std::move(to), now);
  }
  void apply_reload(config::Config next, TimePoint now);
  void start_command(DeviceCommand cmd, TimePoint now);
  // `cobridge acknowledge DEVICE`: contested objects may be written again.
  void acknowledge_contested(const std::string& device, const std::string& caller, TimePoint now);

  // ---- set-up (constructor / reload) -------------------------------------

  void build_devices();
  // A configured device as it starts out, before anything is heard of it:
  // the one way start-up and a reload make one, so both show the same.
  DeviceAgent make_managed(const config::Device& d) const;
  DeviceAgent* find_device(std::string_view name);
  // Any configured device at `node`, also one not seen yet.
  DeviceAgent* find_configured_node(std::uint8_t node);
  DeviceAgent* find_node(std::uint8_t node);

  [[nodiscard]] TimePoint steady_now() const noexcept { return now_; }
  [[nodiscard]] WallTime wall_now() const noexcept { return wall_; }
  // A new Discovery on the state store's memory as it is now (its
  // decisions and promises start over), started when the old one was, told
  // which devices are supervised. After a hold on the state file is released.
  void restart_discovery(TimePoint now);
  // The state store's hold (StateStore::hold) into discovery and the status;
  // a released hold restarts discovery. Start and reload.
  void follow_state_hold(TimePoint now);

  // ---- frames and components ----------------------------------------------

  TimePoint run_components(TimePoint now);

  // Returns true when something was done that deserves another turn at once.
  bool handle_outputs(TimePoint now);
  // True when the interface went down (its devices were taken offline).
  bool handle_bus_events(TimePoint now);

  // Devices may have rebooted unseen while the interface was away (their
  // boot-up went nowhere; a factory-fresh one has no heartbeat to tell us):
  // every device that was identified is checked at once (the quick plan reads
  // its key objects; a device that lost its settings gets the full plan), and
  // discovery probes the configured nodes again for those never identified.
  void on_interface_back(TimePoint now);

  // ---- buses without discovery ---------------------------------------------
  // With `discovery = false` nothing probes the bus, yet the configured
  // devices at their configured node-IDs are configured, at start and after
  // every boot-up. Their identity (0x1018) is read by SDO first, so that a
  // device of another serial or model there is reported, never configured.

  void check_configured_nodes(TimePoint now);
  void start_identity_reads(TimePoint now);
  void finish_identity(DeviceAgent& m, TimePoint now);

  // A device that is offline (or failed for want of answers) but sends
  // frames again is checked and configured: it may have restarted unseen.
  void on_sign_of_life(DeviceAgent& m, TimePoint now);

  // ---- discovery -----------------------------------------------------------

  void on_discovery_event(const DiscoveryEvent& e, TimePoint now);
  void on_identified(const DiscoveryEvent& e, TimePoint now);
  bool drop_unknown_entry(const DiscoveryEvent& e);
  void reconfigure_identified(DeviceAgent& m, const DiscoveryEvent& e, TimePoint now);
  void note_unknown(const DiscoveryEvent& e);
  // Commissioning failed and is tried again: status and log say so.
  void on_retry(const DiscoveryEvent& e);
  bool resolve_description(DeviceAgent& m);

  // ---- configuration ---------------------------------------------------------

  bool start_configurations(TimePoint now);
  [[nodiscard]] PlanRunnerOptions runner_options() const;

  // A runner for a plan on `m` (configuration or command), with the device's
  // SDO client, made on first use.
  std::unique_ptr<PlanRunner> make_runner(DeviceAgent& m, ConfigPlan plan, const PlanRunnerOptions& ro);

  // The device's SDO client, made on first use and re-addressed to its node-ID.
  canopen::SdoClient& sdo_of(DeviceAgent& m);
  bool begin_configuration(DeviceAgent& m, TimePoint now);

  void finish_configuration(DeviceAgent& m, TimePoint now);
  void configuration_failed(DeviceAgent& m, const PlanRunResult& outcome, TimePoint now);
  void note_failure(DeviceAgent& m, const PlanRunResult& outcome);
  void note_configured(DeviceAgent& m, const PlanRunResult& outcome);
  static std::string join_differences(const PlanRunResult& outcome);
  void remember_assignment(const DeviceAgent& m, const std::string& fingerprint);
  void mark_operational(DeviceAgent& m, const PlanRunResult& outcome, TimePoint now, double ms);

  // Plans leave the NMT start to us, so that a device found different by
  // the quick check is not started half configured, and so that the hot path
  // has the device's mapping before its first TPDO.
  bool announce_and_start(DeviceAgent& m, TimePoint now);
  void runners_abort();

  // Ends whatever the runner does; a command's submitter learns why.
  void drop_runner(DeviceAgent& m, const char* why);

  // ---- commands from plugins ---------------------------------------------------

  void report_command(const DeviceAgent& m, const DeviceCommand& cmd, const CommandOutcome& outcome);
  void finish_command(DeviceAgent& m, TimePoint now);

  // ---- supervision -------------------------------------------------------------

  void on_supervisor_change(const Supervisor::Change& c, TimePoint now);
  void note_supervision(DeviceAgent& m, const Supervisor::Change& c, DeviceState before);
  // A flight-recorder capture around a fault seen now (nothing when the
  // recorder is off); `device` empty for the bus itself.
  // Returns the capture's file name (empty: no capture).
  std::string capture(const char* cause, const std::string& device);

  // The heartbeat (or guarding reply) tells the device's NMT state (CiA 301
  // §7.2.8.3.2): the status follows it, and a device another NMT master
  // stopped or sent to pre-operational is started again (policy restart) or
  // left as that master wants it (policy respect); either way it is logged.
  void on_nmt_state(DeviceAgent& m, canopen::NmtState nmt, std::int64_t frame_ns, TimePoint now);
  // The start once more (DeviceAgent::judge_nmt counted it), logged.
  void resend_start(DeviceAgent& m, TimePoint now);
  // Another NMT master stopped the device: `stopped`, and started again
  // when the bus's foreign_nmt is `restart`; logged either way.
  void on_stopped_by_another(DeviceAgent& m, bool restart);

  bool emcy_log_allowed(DeviceAgent& m, TimePoint now) { return m.emcy_log.allow(now); }

  void report_suppressed_emcy(TimePoint now);
  // Frames lost at the control socket's full receive queue (SO_RXQ_OVFL):
  // EMCY, heartbeats and SDO answers this thread never saw, so the log and
  // supervision must say so (the outputs read the hot path's own socket).
  void report_control_drops(TimePoint now);
  std::uint64_t control_drops_reported = 0;
  TimePoint control_drops_report_at{};

  // ---- clients' commands (ServiceGate) ------------------------------------------

  bool node_free(std::uint8_t node) const override;
  bool node_supervised(std::uint8_t node) const override;

  bool lss_allowed() const override { return !discovery->commissioning() && channel->is_open(); }

  void on_nmt_sent(canopen::NmtCommand command, std::uint8_t node, const std::string& caller) override;
  void on_lss_node_id(const canopen::LssAddress& device, std::uint8_t node, bool stored) override;
  void on_sdo_written(const ServiceRequest& c, TimePoint now) override;

  // ---- configuration drift (bus_controller_drift.cpp) ------------------------------

  // A client's confirmed write of index:sub on `m`: recorded, logged and
  // restored or kept per m.cfg.on_config_drift when the plan sets the object
  // to another value; a write of the configured value closes its record.
  void note_client_write(DeviceAgent& m, std::uint16_t index, std::uint8_t sub, std::span<const std::uint8_t> bytes,
                         const std::string& writer, TimePoint now);
  // The drift part of note_client_write.
  void note_drift(DeviceAgent& m, std::uint16_t index, std::uint8_t sub, std::span<const std::uint8_t> bytes,
                  const std::string& writer, TimePoint now);
  // A write another SDO client made on the bus (seen by sdo_observer).
  void on_foreign_write(const canopen::ObservedWrite& w, TimePoint now);
  // Drift of an object a plugin's command wrote (its runner's plan).
  void note_command_writes(DeviceAgent& m, const ConfigPlan& command_plan, const DeviceCommand& cmd, TimePoint now);
  // Asks the device's RestoreGuard: restores after its backoff, or marks
  // the object contested; a drift seen while a plan runs waits for its end.
  void request_restore(DeviceAgent& m, std::uint16_t index, std::uint8_t sub, TimePoint now);
  void mark_contested(DeviceAgent& m, const DriftRecord& r);
  void note_contested_write(DeviceAgent& m, DriftRecord& open, const DriftRecord& now_written);
  // The full plan at `when` (after a backoff, or now).
  void restore_configuration(DeviceAgent& m, TimePoint now, TimePoint when);
  void follow_written_heartbeat(DeviceAgent& m, const DriftRecord& r);
  // After a successful plan: the drift it put right is closed; contested
  // objects and those written while it ran stay open.
  void clear_drift(DeviceAgent& m);
  // Then restores what stayed open and is not contested.
  void restore_left_drift(DeviceAgent& m, TimePoint now);

  // ---- status ------------------------------------------------------------------

  // `why` is the timeline's cause; empty: the device's last_error, or the
  // usual reason for entering `s`.
  void set_state(DeviceAgent& m, DeviceState s, std::string why = {});
  // ---- timelines (bus_controller_timeline.cpp) ---------------------------------

  // A timeline event of `m` (now); `capture` names the recorder's file.
  // A configured device's event is queued for the journal.
  void add_event(DeviceAgent& m, TimelineKind kind, std::string text, std::string capture = {});
  // A bus-wide event (controller, adapter) on the timeline of every device of the bus.
  void add_bus_event(TimelineKind kind, const std::string& text, const std::string& capture);
  // Start-up: the configured devices' timelines from the journal, then a
  // "gateway started" event on each.
  void restore_timelines(TimelineSink::Kept kept);
  // Hands the journal's noted events to its writer thread once per
  // kFlushInterval, or now when `force` (the bus stops); returns when it is
  // next due.
  TimePoint flush_timelines(TimePoint now, bool force = false);
  void notify(const DeviceAgent& m);
  void add_step(StepTiming t);

  // The status board's (status_board.hpp), marking the status for publishing.
  void add_problem(const std::string& text, const std::string& device = {}, std::uint8_t clash_node = 0);

  void update_ready(TimePoint now);
  void publish_if_dirty();
  void publish_all();

  // ---- members -------------------------------------------------------------------

  // Thread contract: everything below up to the atomics belongs to the
  // control thread once the shell started it.
  // The shell's last clock reading (set_time).
  TimePoint now_{};
  WallTime wall_{};
  config::Config config;
  std::size_t bus_index;
  config::Bus bus;
  const device::DeviceCatalog& catalog;
  StateStore& state;
  BusManagerOptions options;
  std::shared_ptr<spdlog::logger> log;

  // The bus (the shell's): a SocketCAN socket on bus.interface, or options.port.
  can::BusPort* channel = nullptr;
  std::unique_ptr<Discovery> discovery;
  // Why node-IDs must not be assigned (the state file could not be read;
  // StateStore::hold): the first of the bus's problems while not empty.
  std::string state_hold;
  std::unique_ptr<ServiceExecutor> services;
  Supervisor supervisor;
  canopen::SyncProducer sync;
  std::vector<DeviceAgent> devices;
  StatusBoard board;  // the bus's problems and step timings
  std::string live_bus_event;
  canopen::SdoObserver sdo_observer;  // other SDO clients' writes (drift)
  TimelineSink* journal = nullptr;  // <state_dir>/timelines/<bus>.timeline (nullptr: none)
  TimePoint journal_due{};
  can::ControllerHealth controller;  // from the channel's error frames and netlink
  // The health told to the outputs (bus_controller_health.cpp).
  bool netlink_failing = false;  // the last read failed (logged once per run of failures)
  BusHealthGate health_gate{std::chrono::seconds(1)};
  [[nodiscard]] TimePoint watch_health(TimePoint now);
  void tell_health(TimePoint now);
  std::uint32_t reopens_seen = 0;
  bool discovery_started = false;
  bool dirty = true;
  TimePoint started_at{};
  // [redundancy]: the bus's master role (bus_controller_election.cpp).
  std::optional<canopen::MasterElection> election;
  // What every component sends through: the channel while this gateway may
  // send (no [redundancy], or master); refused (and counted) otherwise, so
  // no path of a standby reaches the bus, whatever it was asked.
  struct MasterGate final : can::FrameSink {
    explicit MasterGate(BusController& owner) : impl(owner) {}
    bool send(const can::Frame& frame) noexcept override;
    BusController& impl;
    std::uint64_t refused = 0;
  };
  MasterGate tx{*this};
  WallTime election_at{};
  void start_election(TimePoint now);
  [[nodiscard]] bool standby() const noexcept { return election && !election->is_master(); }
  [[nodiscard]] bool election_frame(const can::Frame& frame, TimePoint arrived);
  void on_election(const canopen::ElectionEvent& e);
  void tell_outputs(const canopen::ElectionEvent& e);
  // The node-IDs that are no gateway's, for the election (canopen/election_peers.hpp).
  [[nodiscard]] canopen::NodeSet election_excluded() const;
  void update_election_exclusions();
  LogBudget role_log{kRoleLogLines, kRoleLogWindow};
  void log_role(const canopen::ElectionEvent& e);
  void report_suppressed_roles(TimePoint now);
  [[nodiscard]] TimePoint report_ignored_election_frames(TimePoint now);
  canopen::ElectionCounters ignored_reported{};
  TimePoint ignored_report_at = kNever;
  [[nodiscard]] TimePoint run_standby(TimePoint now, TimePoint next);
  // Standby (bus_controller_standby.cpp): what the master's traffic tells.
  StandbyListener listener;
  void listen_as_standby(const can::Frame& frame, TimePoint now);
  void follow_heard_devices();
  void remember_followed(const DeviceAgent& m, const std::string& fingerprint);
  void describe_role(BusStatus& s) const;

  // Read by the shell's public calls on any thread.
  std::atomic<bool> open_flag{false};
  std::atomic<bool> ready_latched{false};
  std::atomic<std::size_t> services_waiting{0};  // client commands in the executor

  // Shared with the callers of status().
  mutable std::mutex mutex;
  BusStatus published;
};

}  // namespace cobridge::bus
