#include "app/daemon.hpp"

#include "app/log_settings.hpp"
#include "app/reload_rules.hpp"
#include "app/validation.hpp"
#include "sys/journal_sink.hpp"
#include "sys/logging.hpp"

#include <poll.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <future>
#include <utility>
#include <vector>

namespace cobridge::app {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

const char* plural(std::size_t n, const char* many = "s") { return n == 1 ? "" : many; }

// A failure that stops the start, reported once wherever it is read: on
// stderr for an operator in a terminal (in the form --check-config prints),
// in the log (journal priority "err") under systemd, where stderr is the
// journal too; in both only when the log goes elsewhere than stderr (a
// journal target chosen in a terminal).
class FatalReport {
 public:
  FatalReport()
      : print_(!sys::stderr_is_journal()), log_(!print_ || !sys::log_reaches_stderr()) {}
  void line(const std::string& logged, const std::string& printed) const {
    if (log_) sys::logger("gateway")->error("{}", logged);
    if (print_) std::fprintf(stderr, "%s\n", printed.c_str());
  }

 private:
  bool print_;
  bool log_;
};

}  // namespace

Daemon::Daemon(DaemonOptions options) : options_(std::move(options)) {}

Daemon::~Daemon() = default;

Error Daemon::start() {
  if (const Error& e = signals_.error()) {
    std::fprintf(stderr, "cobridged: %s\n", e.to_string().c_str());
    return e;
  }
  if (Error e = load_configuration()) return e;
  auto log = sys::logger("gateway");
  notifier_.emplace();
  state_.emplace(cfg_->gateway.state_dir);
  // A file that cannot be read is set aside and holds every assignment
  // (bus::StateStore); the daemon runs on, and says so here and in status.
  if (const Error e = state_->load()) log->error("state file {}", e.to_string());
  // The bus threads never wait for the disk: their heartbeat and LSS steps
  // are timed (bus/state_store.hpp).
  state_->start_writer();

  // Made here, started below once the control socket is ours; the control
  // socket's status reads its hot-path counters.
  outputs_.emplace(*cfg_, *catalog_, options_.plugin_dir);
  facade_.emplace(*cfg_, buses_, *outputs_, options_.version, &recorders_, &*state_);
  // The control socket first: a second daemon started by mistake stops here,
  // before it touches a bus the first one serves.
  control::ControlServerOptions control_options;
  control_options.services = &registry_;
  control_.emplace(*facade_, control_options);
  if (const Error e = control_->open(cfg_->gateway.control_socket)) {
    FatalReport().line("control socket: " + e.to_string(), "cobridged: control socket: " + e.to_string());
    return Error(Errc::kFailed, "control socket: " + e.message, e.where, e.code);
  }
  open_beacons();
  if (Error e = output_problems(outputs_->load(), "no bus was touched")) return e;
  start_recorders();
  if (Error e = output_problems(outputs_->start_receivers(), "no bus was touched")) return e;
  // The plugins start (a DDS participant takes tenths of a second) while the
  // buses come up; the dispatcher holds what the buses produce meanwhile.
  auto plugins = std::async(std::launch::async, [this] { return start_plugins(); });
  buses_.build(*cfg_, *catalog_, *state_, *outputs_, registry_, &recorders_);
  const Error bus_error = buses_.start();
  std::vector<Error> plugin_problems = plugins.get();
  if (bus_error) {
    FatalReport().line(bus_error.to_string(), "cobridged: " + bus_error.to_string());
    return Error(Errc::kFailed, bus_error.message, bus_error.where, bus_error.code);
  }
  if (Error e = output_problems(std::move(plugin_problems), "the buses were stopped again")) {
    buses_.stop();
    outputs_->stop();
    return e;
  }
  if (Error e = start_web()) return e;
  service_.emplace(*notifier_, buses_, *facade_);
  return {};
}

Error Daemon::load_configuration() {
  const auto& file = options_.config_file;
  Validated v = validate(file);
  if (!v.config) {
    print(v, stderr);
    std::fprintf(stderr, "cobridged: %s: %zu error%s; no bus was touched\n", file.c_str(), v.errors.size(),
                 plural(v.errors.size()));
    return Error(Errc::kFailed, std::to_string(v.errors.size()) + " configuration error" + plural(v.errors.size()),
                 file.string());
  }
  cfg_ = std::make_unique<config::Config>(std::move(*v.config));
  if (!options_.state_dir_override.empty()) cfg_->gateway.state_dir = options_.state_dir_override;
  apply_logging(cfg_->logging, options_.foreground);
  auto log = sys::logger("gateway");
  for (const auto& w : v.warnings) log->warn("{}", w);
  catalog_ = std::move(v.catalog);
  log->info("cobridged {} starting: {} ({} buses, {} devices, {} device descriptions)", options_.version,
            file.string(), cfg_->buses.size(), cfg_->devices.size(), catalog_->size());
  return {};
}

// Makes this daemon findable from each interface it serves (the CLI then
// goes through the control socket instead of opening the bus beside it).
// Another daemon on the same interface is a second master: said loudly, not
// refused. In a hot-standby pair ([redundancy]) it is the peer: the beacon
// stays with the first gateway and retry_beacons() takes it over when that
// one is gone, so the CLI always finds a daemon and never opens the bus.
void Daemon::open_beacons() {
  auto log = sys::logger("gateway");
  const std::string control = std::filesystem::absolute(cfg_->gateway.control_socket).string();
  beacons_.resize(cfg_->buses.size());
  for (std::size_t i = 0; i < cfg_->buses.size(); ++i) {
    const auto& bus = cfg_->buses[i];
    if (const Error e = beacons_[i].open(bus.interface, control)) {
      if (cfg_->redundancy) {
        log->info("bus {}: the peer gateway answers the CLI for {} for now", bus.name, bus.interface);
      } else {
        log->warn("bus {}: {}", bus.name, e.to_string());
      }
    }
  }
}

void Daemon::start_recorders() {
  auto log = sys::logger("gateway");
  recorders_.build(*cfg_);
  for (std::size_t i = 0; i < cfg_->buses.size(); ++i) {
    outputs_->set_recorder(i, recorders_.recorder(i));
    if (const can::FrameRecorder* r = recorders_.recorder(i)) {
      log->info("bus {}: flight recorder of {} s, {} frames, {} KiB", cfg_->buses[i].name,
                cfg_->buses[i].recorder_seconds, r->capacity(), r->memory_bytes() / 1024);
    }
  }
  for (const Error& e : recorders_.start()) log->warn("flight recorder: no captures: {}", e.to_string());
}

void Daemon::retry_beacons(Clock::time_point now) {
  if (!cfg_->redundancy || now < next_beacon_try_) return;
  next_beacon_try_ = now + std::chrono::seconds(1);
  const std::string control = std::filesystem::absolute(cfg_->gateway.control_socket).string();
  for (std::size_t i = 0; i < beacons_.size() && i < cfg_->buses.size(); ++i) {
    if (beacons_[i].fd() >= 0) continue;
    const auto& bus = cfg_->buses[i];
    if (!beacons_[i].open(bus.interface, control))
      sys::logger("gateway")->info("bus {}: the CLI finds this gateway for {} now", bus.name, bus.interface);
  }
}

// A problem of the outputs is fatal: reported once, with what became of the
// buses (`aftermath`).
Error Daemon::output_problems(std::vector<Error> problems, const char* aftermath) {
  if (problems.empty()) return {};
  const FatalReport report;
  for (const auto& p : problems) report.line("outputs: " + p.to_string(), p.to_string());
  const std::string summary = options_.config_file.string() + ": " + std::to_string(problems.size()) +
                              " output problem" + plural(problems.size()) + "; " + aftermath;
  report.line(summary, "cobridged: " + summary);
  return Error(Errc::kFailed, std::to_string(problems.size()) + " output problem" + plural(problems.size()),
               options_.config_file.string());
}

// Runs on a helper thread while the main thread starts the buses; logs when
// the plugins run, so the log shows when the outputs were ready.
std::vector<Error> Daemon::start_plugins() {
  std::vector<Error> problems = outputs_->start_plugins();
  if (problems.empty())
    sys::logger("gateway")->info("outputs: {} plugin{} running from {}", outputs_->plugins_running(),
                                 plural(outputs_->plugins_running()), options_.plugin_dir.string());
  return problems;
}

// The web service last: it reads the status of running buses. A daemon told
// to serve it does not run without it (like an output).
Error Daemon::start_web() {
  web_.emplace([this] { return facade_->status(); });
  web_->set_captures([this](std::string_view name) { return facade_->read_capture(name); });
  if (!cfg_->web || !cfg_->web->enabled) return {};
  if (const Error e = web_->start(*cfg_->web)) {
    FatalReport().line("web: " + e.to_string(), "cobridged: web: " + e.to_string());
    buses_.stop();
    outputs_->stop();
    return Error(Errc::kFailed, "web: " + e.message, e.where, e.code);
  }
  return {};
}

void Daemon::serve() {
  std::vector<pollfd> fds;
  while (true) {
    // One clock read per turn: each is a system call under UML, and this
    // loop answers clients' SDO commands.
    const auto now = Clock::now();
    service_->tick(now);
    retry_beacons(now);
    const auto deadline = std::min(service_->next_deadline(), control_->process(now));
    fds.clear();
    fds.push_back({signals_.fd(), POLLIN, 0});
    for (const auto& b : beacons_) fds.push_back({b.fd(), POLLIN, 0});
    control_->add_poll_fds(fds);
    const auto wait = std::clamp(std::chrono::duration_cast<milliseconds>(deadline - now), milliseconds(0),
                                 ServiceStatus::kTick);
    const int r = ::poll(fds.data(), fds.size(), static_cast<int>(wait.count()) + (deadline > now ? 1 : 0));
    control_->note_ready(fds);
    for (std::size_t i = 0; r > 0 && i < beacons_.size(); ++i)
      if (fds[1 + i].revents != 0) beacons_[i].serve();
    if (r < 0 || fds[0].revents == 0) continue;
    const sys::SignalAction action = signals_.take();
    if (action == sys::SignalAction::stop) return;
    if (action == sys::SignalAction::reload) reload();
  }
}

void Daemon::stop() {
  const auto t0 = Clock::now();
  auto log = sys::logger("gateway");
  service_->stopping();
  log->info("stopping");
  web_->stop();
  // The reverse of the start: no more plugin commands to the buses, the
  // buses (their last status and command outcomes still reach the hot
  // path), then the hot path and the plugins, then the control socket.
  for (std::size_t i = 0; i < buses_.size(); ++i) outputs_->set_command_target(i, nullptr);
  buses_.stop();
  state_->stop_writer();  // what the buses remembered last, on disk
  outputs_->stop();
  recorders_.stop();
  control_->close();
  beacons_.clear();
  log->info("stopped in {} ms", std::chrono::duration_cast<milliseconds>(Clock::now() - t0).count());
}

// A held state file (it could not be read, bus::StateStore) is read
// again at every reload: the operator's decision is a file that reads
// (docs/operations.md, "A state file that cannot be read"). True when the
// hold changed (released, or another file set aside).
bool Daemon::reload_state() {
  const std::string before = state_->hold();
  if (before.empty()) return false;
  auto log = sys::logger("gateway");
  if (const Error e = state_->load()) {
    log->error("state file {}", e.to_string());
  } else {
    log->info("state file {} reads; node-IDs are assigned again", state_->path().string());
  }
  return state_->hold() != before;
}

// Every part takes the new configuration, or none does.
void Daemon::reload() {
  auto log = sys::logger("gateway");
  service_->reloading();
  log->info("SIGHUP: reloading {}", options_.config_file.string());
  const bool state_news = reload_state();
  Validated next = validate(options_.config_file);
  std::string refusal;
  if (next.config) {
    if (!options_.state_dir_override.empty()) next.config->gateway.state_dir = options_.state_dir_override;
    refusal = reload_refusal(*cfg_, *next.config);
    if (refusal.empty()) refusal = outputs_->reload(*next.config);
    if (!refusal.empty()) refusal += " (needs a restart)";
  }
  if (!next.config || !refusal.empty()) {
    for (const auto& e : next.errors) log->error("{}", e.to_string());
    if (!refusal.empty()) log->error("reload rejected: {}", refusal);
    log->error("reload rejected; still running the previous configuration");
    // The state file's news reach the buses all the same.
    if (state_news) buses_.reload(*cfg_);
    const std::size_t n = next.errors.size();
    service_->reloaded("; reload rejected (" +
                       (refusal.empty() ? std::to_string(n) + (n == 1 ? " config error" : " config errors") : refusal) +
                       ")");
    return;
  }
  for (const auto& w : next.warnings) log->warn("{}", w);
  // New description files are not picked up by a reload: the buses keep the
  // catalog they started with (a restart loads new ones).
  auto fresh = std::make_unique<config::Config>(std::move(*next.config));
  apply_logging(fresh->logging, options_.foreground);
  buses_.reload(*fresh);
  facade_->set_config(*fresh);
  cfg_ = std::move(fresh);
  service_->reloaded({});
  log->info("reloaded: {} devices", cfg_->devices.size());
}

}  // namespace cobridge::app
