// BusManager::Impl: the state and the work of one bus's control thread,
// private to daemon/bus/bus_manager*.cpp. The members are defined by
// concept: bus_manager.cpp (construction, the thread loop, commands from
// other threads, the public API), bus_manager_frames.cpp (frames, outputs
// and bus events of the protocol components; supervision),
// bus_manager_discovery.cpp (discovery and the identity check of buses
// without it), bus_manager_configure.cpp (configuration plans and plugins'
// commands), bus_manager_service.cpp (the ServiceGate for clients' commands),
// bus_manager_drift.cpp (clients' writes of configured objects),
// bus_manager_health.cpp (the controller over netlink, the bus's health to
// the observer) and bus_manager_status.cpp (the published status). What
// is decided from one device's own record and the time alone is the
// device's (bus/device_agent.hpp): these files act on its verdicts.
//
// Threads: everything runs on the bus's control thread except the public
// BusManager calls (any thread), which touch only the atomics and what
// `mutex` guards (see the thread contract at the members below).
#pragma once

#include "bus/bus_manager.hpp"

#include "can/bus_event.hpp"
#include "can/controller_netlink.hpp"
#include "can/socketcan_channel.hpp"
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
#include "bus/stamp_clock.hpp"
#include "bus/plan_runner.hpp"
#include "bus/service/service_executor.hpp"
#include "bus/service/service_target.hpp"
#include "bus/supervisor.hpp"
#include "bus/timeline_journal_thread.hpp"
#include "sys/logging.hpp"

#include <poll.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <optional>
#include <thread>

namespace cobridge::bus {

namespace {

using canopen::kNever;
using canopen::TimePoint;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

constexpr std::size_t kMaxSteps = 64;            // StepTiming entries kept in the status
constexpr std::size_t kMaxProblems = 32;         // problems kept in the status
constexpr std::size_t kMaxConcurrentPlans = 2;   // plan runners at once per bus
constexpr std::size_t kMaxReceiveBatches = 16;   // per loop turn, so timers still run under load
constexpr milliseconds kMaxPollWait{1000};
constexpr milliseconds kRebootFallbackDelay{500};
constexpr std::size_t kMaxQueuedCommands = 16;    // per bus, waiting for the control thread
constexpr std::size_t kMaxServiceRequests = 256;   // client commands per bus, queued or waiting for their node
// A re-plugged adapter is opened at most this long after it appears, so
// its devices are configured again within 2 s of its return.
constexpr milliseconds kReopenBackoffMax{500};
// The control socket's receive queue carries the control plane over a
// stall of its thread (a loaded host, an EMCY storm at 1 500 frames/s): the
// kernel's default holds some 300 frames, 200 ms of such a storm.
constexpr int kControlReceiveBuffer = 1 << 20;
// Frames the kernel dropped there are logged at most this often, summed up.
constexpr milliseconds kControlDropReportPeriod{1000};
// Role changes logged per window; more are counted and summed up in one line.
constexpr std::uint32_t kRoleLogLines = 6;
constexpr std::chrono::seconds kRoleLogWindow{60};

}  // namespace

struct BusManager::Impl final : ServiceGate {
  Impl(const config::Config& config_in, std::size_t index, const device::DeviceCatalog& catalog_in,
       StateStore& state_in, BusManagerOptions options_in);

  // ---- set-up (constructor / reload) -------------------------------------

  void build_devices();
  // A configured device as it starts out, before anything is heard of it:
  // the one way start-up and a reload make one, so both show the same.
  DeviceAgent make_managed(const config::Device& d) const;
  DeviceAgent* find_device(std::string_view name);
  // Any configured device at `node`, also one not seen yet.
  DeviceAgent* find_configured_node(std::uint8_t node);
  DeviceAgent* find_node(std::uint8_t node);

  // ---- thread ------------------------------------------------------------

  // The wake fd lives as long as the Impl: a submit() or reload() racing
  // with stop() then writes into a live eventfd, never into a closed (and
  // possibly reused) descriptor.
  ~Impl();
  // The port (a socket on the interface, or options.port) with its filters.
  Error open_port();
  Error start();
  void stop();
  void wake() noexcept;
  void run();
  // One turn of the control loop at `now`: commands, frames, components;
  // returns the next deadline. `now` moves on when the turn reads the
  // clock again (work it started gets a turn at once).
  TimePoint turn(TimePoint& now);
  // After the last turn: the journal flushed, the components ended.
  void finish_run();
  [[nodiscard]] TimePoint steady_now() const noexcept { return clock.now(); }
  [[nodiscard]] WallTime wall_now() const noexcept { return clock.wall(); }
  void start_components(TimePoint now);
  // A new Discovery on the state store's memory as it is now (its
  // decisions and promises start over), started when the old one was, told
  // which devices are supervised. After a hold on the state file is released.
  void restart_discovery(TimePoint now);
  // The state store's hold (StateStore::hold) into discovery and the status;
  // a released hold restarts discovery. Start and reload.
  void follow_state_hold(TimePoint now);
  bool receive(std::span<can::Frame> frames, TimePoint now);
  void wait(TimePoint now, TimePoint next);

  // ---- frames and components ----------------------------------------------

  void dispatch(const can::Frame& frame, TimePoint now);
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
  void start_command(DeviceCommand cmd, TimePoint now);
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

  // ---- commands from other threads ------------------------------------------

  void take_commands(TimePoint now);
  void apply_reload(config::Config next, TimePoint now);

  // ---- clients' commands (ServiceGate) ------------------------------------------

  bool node_free(std::uint8_t node) const override;
  bool node_supervised(std::uint8_t node) const override;

  bool lss_allowed() const override { return !discovery->commissioning() && channel->is_open(); }

  void on_nmt_sent(canopen::NmtCommand command, std::uint8_t node, const std::string& caller) override;
  void on_lss_node_id(const canopen::LssAddress& device, std::uint8_t node, bool stored) override;
  void on_sdo_written(const ServiceRequest& c, TimePoint now) override;

  // ---- configuration drift (bus_manager_drift.cpp) ------------------------------

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
  // `cobridge acknowledge DEVICE`: contested objects may be written again.
  void acknowledge_contested(const std::string& device, const std::string& caller, TimePoint now);

  // ---- status ------------------------------------------------------------------

  // `why` is the timeline's cause; empty: the device's last_error, or the
  // usual reason for entering `s`.
  void set_state(DeviceAgent& m, DeviceState s, std::string why = {});
  // ---- timelines (bus_manager_timeline.cpp) ---------------------------------

  // A timeline event of `m` (now); `capture` names the recorder's file.
  // A configured device's event is queued for the journal.
  void add_event(DeviceAgent& m, TimelineKind kind, std::string text, std::string capture = {});
  // A bus-wide event (controller, adapter) on the timeline of every device of the bus.
  void add_bus_event(TimelineKind kind, const std::string& text, const std::string& capture);
  // Start-up: the configured devices' timelines from the journal, then a
  // "gateway started" event on each.
  void restore_timelines();
  // Hands the journal's noted events to its writer thread once per
  // kFlushInterval, or now when `force` (the bus stops); returns when it is
  // next due.
  TimePoint flush_timelines(TimePoint now, bool force = false);
  void notify(const DeviceAgent& m);
  void add_step(StepTiming t);

  // A problem stays in the status while it is true: a device's own problems
  // leave when it is operational, a clash's when it is resolved.
  void add_problem(const std::string& text, const std::string& device = {}, std::uint8_t clash_node = 0);

  template <typename Pred>
  void clear_problems(Pred pred) {
    if (std::erase_if(problems, pred) != 0) dirty = true;
  }

  void update_ready(TimePoint now);
  void publish_if_dirty();
  void publish_all();

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

  const BusClock& clock;
  // The bus: `socket` (SocketCAN on bus.interface), or options.port.
  std::unique_ptr<can::SocketCanChannel> socket;
  can::BusPort* channel = nullptr;
  std::array<can::Frame, can::SocketCanChannel::kBatch> rx_frames{};
  std::unique_ptr<Discovery> discovery;
  // Why node-IDs must not be assigned (the state file could not be read;
  // StateStore::hold): the first of the bus's problems while not empty.
  std::string state_hold;
  std::unique_ptr<ServiceExecutor> services;
  Supervisor supervisor;
  canopen::SyncProducer sync;
  std::vector<DeviceAgent> devices;
  std::vector<StepTiming> steps;
  struct Problem {
    std::string text;
    std::string device;          // the configured device it is about (empty: the bus)
    std::uint8_t clash_node = 0; // a clash at this node-ID
  };
  std::vector<Problem> problems;
  std::string live_bus_event;
  canopen::SdoObserver sdo_observer;  // other SDO clients' writes (drift)
  std::unique_ptr<TimelineJournalThread> journal;  // <state_dir>/timelines/<bus>.timeline
  TimePoint journal_due{};
  can::ControllerHealth controller;  // from the channel's error frames and netlink
  // The controller over netlink and the health told to the outputs
  // (bus_manager_health.cpp).
  can::ControllerNetlink netlink;
  TimePoint netlink_due{};
  bool netlink_failing = false;  // the last read failed (logged once per run of failures)
  BusHealthGate health_gate{std::chrono::seconds(1)};
  [[nodiscard]] TimePoint watch_health(TimePoint now);
  void poll_netlink();
  void tell_health(TimePoint now);
  std::uint32_t reopens_seen = 0;
  bool discovery_started = false;
  bool dirty = true;
  TimePoint started_at{};
  // [redundancy]: the bus's master role (bus_manager_election.cpp).
  std::optional<canopen::MasterElection> election;
  // What every component sends through: the channel while this gateway may
  // send (no [redundancy], or master); refused (and counted) otherwise, so
  // no path of a standby reaches the bus, whatever it was asked.
  struct MasterGate final : can::FrameSink {
    explicit MasterGate(Impl& owner) : impl(owner) {}
    bool send(const can::Frame& frame) noexcept override;
    Impl& impl;
    std::uint64_t refused = 0;
  };
  MasterGate tx{*this};
  WallTime election_at{};
  void start_election(TimePoint now);
  [[nodiscard]] bool standby() const noexcept { return election && !election->is_master(); }
  [[nodiscard]] bool election_frame(const can::Frame& frame, TimePoint now);
  // When `frame` reached the socket, on the steady clock (stamp_clock.hpp).
  [[nodiscard]] TimePoint arrival(const can::Frame& frame, TimePoint now) {
    return stamps.arrival(frame.timestamp_ns, now);
  }
  StampClock stamps{clock};
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
  // Standby (bus_manager_standby.cpp).
  std::array<canopen::LssAddress, 128> heard_identity{};  // per node, from the master's 0x1018 reads
  // Per node: the 0x1018 sub-index of the upload the standby saw requested
  // (0 = none) and when; only its response within the SDO timeout counts.
  struct AskedIdentity {
    std::uint8_t sub = 0;
    TimePoint at{};
  };
  std::array<AskedIdentity, 128> asked_identity{};
  void listen_as_standby(const can::Frame& frame, TimePoint now);
  void note_heartbeat(const can::Frame& frame);
  void note_identity_request(const can::Frame& frame, TimePoint now);
  void note_identity(const can::Frame& frame, TimePoint now);
  void follow_heard_devices();
  void remember_followed(const DeviceAgent& m, const std::string& fingerprint);
  void describe_role(BusStatus& s) const;

  std::thread thread;
  int wake_fd = -1;
  bool rx_ready = true;  // the last poll saw the CAN socket readable (or failed)
  // The deadline the last poll waited for: a turn at or past it judges
  // timeouts, so it reads the socket first even after a command's wake-up.
  TimePoint polled_for = kNever;
  std::vector<pollfd> poll_fds;  // wait()'s, kept for its capacity
  std::atomic<bool> stop_requested{false};
  std::atomic<bool> running{false};
  std::atomic<bool> open_flag{false};
  std::atomic<bool> ready_latched{false};
  std::atomic<Clock::rep> loop_alive{0};
  std::atomic<std::size_t> services_waiting{0};  // client commands in the executor (kMaxServiceRequests)  // steady_clock ticks of the last loop turn (watchdog)

  // Shared with the callers of status()/reload()/request_commission().
  mutable std::mutex mutex;
  BusStatus published;
  bool commission_requested = false;
  std::vector<std::pair<std::string, std::string>> pending_acks;  // (device, caller)
  std::optional<config::Config> pending_reload;
  std::deque<DeviceCommand> pending_commands;
  std::deque<std::pair<ServiceRequest, std::shared_ptr<ServiceReplies>>> pending_services;
};

}  // namespace cobridge::bus
