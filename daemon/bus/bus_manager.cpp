// BusManager: the shell of one bus's controller (bus_controller.hpp). It
// owns what the controller must not: the control thread and its loop, the
// socket (or a test's port) and its poll, the clocks (and the frames'
// kernel stamps on them), netlink, the timeline journal's writer thread,
// and the hand-over of commands from other threads; and the public API
// (bus_manager.hpp).
#include "bus/bus_controller.hpp"
#include "bus/capture_writer.hpp"
#include "bus/stamp_clock.hpp"
#include "bus/timeline_journal_thread.hpp"
#include "can/socketcan_channel.hpp"

#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <cerrno>
#include <deque>
#include <thread>

namespace cobridge::bus {

namespace {

constexpr std::size_t kMaxReceiveBatches = 16;  // per loop turn, so timers still run under load
constexpr milliseconds kMaxPollWait{1000};
constexpr std::size_t kMaxQueuedCommands = 16;   // per bus, waiting for the control thread
constexpr std::size_t kMaxServiceRequests = 256;  // client commands per bus, queued or waiting for their node
// A re-plugged adapter is opened at most this long after it appears, so
// its devices are configured again within 2 s of its return.
constexpr milliseconds kReopenBackoffMax{500};
// The control socket's receive queue carries the control plane over a
// stall of its thread (a loaded host, an EMCY storm at 1 500 frames/s): the
// kernel's default holds some 300 frames, 200 ms of such a storm.
constexpr int kControlReceiveBuffer = 1 << 20;
// A netlink round trip per second and bus: cheap, and a counter or a
// state whose error frame was lost is at most this old.
constexpr milliseconds kNetlinkPeriod{1000};

// The journal of the bus's timelines, its history read into `kept`.
std::unique_ptr<TimelineJournalThread> open_journal(const StateStore& state, const std::string& bus,
                                                    TimelineSink::Kept& kept) {
  TimelineJournal file(state.path().parent_path(), bus);
  if (Error err = file.load(kept)) sys::logger("gateway")->warn("bus {}: timeline journal: {}", bus, err.to_string());
  return std::make_unique<TimelineJournalThread>(std::move(file), bus);
}

}  // namespace

struct BusManager::Impl {
  Impl(const config::Config& config, std::size_t index, const device::DeviceCatalog& catalog, StateStore& state,
       BusManagerOptions options_in)
      : options(options_in),
        clock(options_in.clock != nullptr ? *options_in.clock : system_bus_clock()),
        journal(open_journal(state, config.buses.at(index).name, kept)),
        ctl(config, index, catalog, state, options_in, journal.get(), std::move(kept), clock.now(), clock.wall()) {
    wake_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  }
  // The wake fd lives as long as the Impl: a submit() or reload() racing
  // with stop() then writes into a live eventfd, never into a closed (and
  // possibly reused) descriptor.
  ~Impl() {
    if (wake_fd >= 0) ::close(wake_fd);
  }

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
  void clock_reading(TimePoint now) { ctl.set_time(now, clock.wall()); }
  bool receive(TimePoint now);
  // The CAN controller over netlink when due (a socket's interface only);
  // returns when it is next due.
  TimePoint read_netlink(TimePoint now);
  void wait(TimePoint now, TimePoint next);
  void take_commands(TimePoint now);
  void finish_run();

  BusManagerOptions options;
  const BusClock& clock;
  TimelineSink::Kept kept;  // the journal's history, until the controller takes it
  std::unique_ptr<TimelineJournalThread> journal;  // <state_dir>/timelines/<bus>.timeline
  BusController ctl;

  // The bus: `socket` (SocketCAN on bus.interface), or options.port.
  std::unique_ptr<can::SocketCanChannel> socket;
  can::BusPort* channel = nullptr;
  std::array<can::Frame, can::SocketCanChannel::kBatch> rx_frames{};
  StampClock stamps{clock};
  can::ControllerNetlink netlink;
  TimePoint netlink_due{};

  std::thread thread;
  int wake_fd = -1;
  bool rx_ready = true;  // the last poll saw the CAN socket readable (or failed)
  // The deadline the last poll waited for: a turn at or past it judges
  // timeouts, so it reads the socket first even after a command's wake-up.
  TimePoint polled_for = kNever;
  std::vector<pollfd> poll_fds;  // wait()'s, kept for its capacity
  std::atomic<bool> stop_requested{false};
  std::atomic<bool> running{false};
  std::atomic<Clock::rep> loop_alive{0};  // steady_clock ticks of the last loop turn (watchdog)

  // Shared with the callers of reload(), request_commission(), submit...
  std::mutex mutex;
  bool commission_requested = false;
  std::vector<std::pair<std::string, std::string>> pending_acks;  // (device, caller)
  std::optional<config::Config> pending_reload;
  std::deque<DeviceCommand> pending_commands;
  std::deque<std::pair<ServiceRequest, std::shared_ptr<ServiceReplies>>> pending_services;
};

Error BusManager::Impl::open_port() {
  const std::string where = "bus " + ctl.bus.name;
  if (options.port != nullptr) {
    channel = options.port;
    ctl.attach(*channel);
    return {};
  }
  can::SocketCanConfig cc;
  cc.interface = ctl.bus.interface;
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
  ctl.attach(*channel);
  return {};
}

Error BusManager::Impl::start() {
  if (wake_fd < 0)
    return Error(Errc::kUnavailable, "no eventfd for the control thread", "bus " + ctl.bus.name,
                 std::make_error_code(std::errc::too_many_files_open));
  if (Error e = open_port()) return e;
  const TimePoint now = clock.now();
  clock_reading(now);
  ctl.opened(now);
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
  const TimePoint start = clock.now();
  clock_reading(start);
  ctl.start_components(start);
  while (!stop_requested.load(std::memory_order_relaxed)) {
    TimePoint now = clock.now();
    const TimePoint next = turn(now);
    wait(now, next);
  }
  finish_run();
}

TimePoint BusManager::Impl::turn(TimePoint& now) {
  clock_reading(now);
  take_commands(now);
  // A wake-up for a command that found the socket empty then, in a turn that
  // runs past a deadline (the thread preempted after poll: a loaded host):
  // frames came meanwhile, and a heartbeat left unread would count as silence
  // (a returning standby negotiated while the master's heartbeat sat unread,
  // vcan_daemon_hot_standby 2026-11-30).
  if (now >= polled_for) rx_ready = true;
  const bool lost = receive(now);  // the interface went down in this turn
  loop_alive.store(now.time_since_epoch().count(), std::memory_order_relaxed);
  TimePoint next = std::min(read_netlink(now), ctl.process(now, lost));
  // Handling the components' output may have started new work (a plan,
  // a reconfiguration): give it a turn at once rather than a poll later.
  // That handling can take milliseconds (the state store's fsync of a
  // node-ID just assigned): what the socket took in meanwhile is
  // dispatched before a component judges its timeouts at the new time, or
  // a Fastscan answer waiting there would count as silence. (LssMaster
  // judges an answer by its kernel stamp: one that came in time is in
  // time, however late the turn gets to it.)
  while (ctl.handle_outputs(now)) {
    now = clock.now();
    clock_reading(now);
    rx_ready = true;
    if (receive(now)) ctl.open_flag.store(channel->is_open());
    next = std::min(read_netlink(now), ctl.run_components(now));
  }
  return std::min(next, ctl.settle(now));
}

void BusManager::Impl::finish_run() {
  clock_reading(clock.now());
  ctl.finish_run(ctl.steady_now());
  channel->close();
}

// Receives and dispatches what the socket holds; true when the interface
// went down meanwhile. Only when poll saw the socket readable (or never
// asked): an empty recvmmsg is a system call per turn, and a turn per client
// command. A frame's arrival on the steady clock is worked out only for the
// election, the one component that judges by it.
bool BusManager::Impl::receive(TimePoint now) {
  bool lost = false;
  for (std::size_t batch = 0; rx_ready && batch < kMaxReceiveBatches; ++batch) {
    const std::size_t n = channel->receive(rx_frames);
    for (std::size_t i = 0; i < n; ++i) {
      const can::Frame& f = rx_frames[i];
      ctl.on_frame(f, now, ctl.judges_arrival() ? stamps.arrival(f.timestamp_ns, now) : now);
    }
    lost = ctl.on_port_events(now) || lost;
    if (n < rx_frames.size()) break;
  }
  return lost;
}

TimePoint BusManager::Impl::read_netlink(TimePoint now) {
  if (now >= netlink_due) {
    // A test's in-process bus has no kernel interface to ask.
    if (socket != nullptr) ctl.on_netlink(netlink.read(ctl.bus.interface));
    netlink_due = now + kNetlinkPeriod;
  }
  return netlink_due;
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
  for (auto& [c, to] : clients) ctl.add_service(std::move(c), std::move(to), now);
  if (commission) ctl.request_commission();
  for (const auto& [device, caller] : acks) ctl.acknowledge_contested(device, caller, now);
  if (reload_config) ctl.apply_reload(std::move(*reload_config), now);
  for (auto& c : commands) ctl.start_command(std::move(c), now);
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
    return Error(Errc::kFailed, "already started", "bus " + impl_->ctl.bus.name,
                 std::make_error_code(std::errc::device_or_resource_busy));
  ServiceBus rb{impl_->ctl.bus.name, impl_->ctl.bus.interface, static_cast<unsigned>(impl_->ctl.bus_index + 1)};
  const config::ServiceAccess access = impl_->ctl.config.services;
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
    return Error(Errc::kFailed, "already started", "bus " + impl_->ctl.bus.name,
                 std::make_error_code(std::errc::device_or_resource_busy));
  if (Error e = impl_->open_port()) return e;
  const TimePoint now = impl_->clock.now();
  impl_->clock_reading(now);
  impl_->ctl.opened(now);
  impl_->running.store(true);
  impl_->ctl.start_components(now);
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
  if (impl_->ctl.ready_latched.load()) return true;
  // Also true when the thread is late to notice the timeout (or never ran).
  const TimePoint started = impl_->ctl.started_at;
  return started != TimePoint{} && impl_->clock.now() - started >= impl_->options.ready_timeout;
}

bool BusManager::serving() const {
  // Alive, not "every interface open": a bus waiting for its adapter must not
  // stop the watchdog, or systemd would restart the daemon and take the other
  // buses down with it. The loop turns at least every kMaxPollWait.
  const Clock::time_point last{Clock::duration{impl_->loop_alive.load(std::memory_order_relaxed)}};
  return impl_->running.load() && impl_->clock.now() - last < 3 * kMaxPollWait;
}

BusStatus BusManager::status() const {
  BusStatus s;
  {
    const std::lock_guard lock(impl_->ctl.mutex);
    s = impl_->ctl.published;
  }
  s.open = impl_->ctl.open_flag.load();
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
    if (impl_->pending_services.size() + impl_->ctl.services_waiting.load(std::memory_order_relaxed) >= kMaxServiceRequests)
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
