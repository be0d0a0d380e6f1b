// cobridged: the gateway daemon. This file only wires the layers together:
// configuration -> logging -> signals -> device catalog -> state store ->
// one BusManager per bus -> control socket -> main loop (signals, control
// socket, sd_notify READY/STATUS/WATCHDOG, SIGHUP reload, SIGTERM stop).
//
// Threads: main() is the main loop; each BusManager runs its own control
// thread. The signals are blocked before any thread starts and read through
// a signalfd here, so nothing runs in a signal handler.
#include "config/known_models.hpp"
#include "config/load.hpp"
#include "device/device_catalog.hpp"
#include "device/family_profile.hpp"
#include "device/eds.hpp"
#include "gateway/bus_manager.hpp"
#include "gateway/control_server.hpp"
#include "gateway/output_pipeline.hpp"
#include "gateway/state_store.hpp"
#include "sys/install_paths.hpp"
#include "sys/logging.hpp"
#include "sys/notifier.hpp"
#include "sys/signals.hpp"
#include "web/web_server.hpp"

#include <CLI/CLI.hpp>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace {

using namespace cobridge;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

constexpr milliseconds kTick{100};  // READY / STATUS checks

// ---- configuration check -------------------------------------------------

std::string_view family_name(config::Family f) {
  switch (f) {
    case config::Family::novotechnik_rotary: return "novotechnik-rotary";
    case config::Family::novotechnik_multiturn: return "novotechnik-multiturn";
    case config::Family::ifm_rm: return "ifm-rm";
  }
  return "";
}

std::string hex(std::uint32_t v) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "0x%X", v);
  return buf;
}

std::string at(const config::SourceLocation& where, std::string message) {
  return config::to_string(config::Diagnostic{where.file, where.line, where.column, std::move(message)});
}

bool same_file(const std::filesystem::path& a, const std::filesystem::path& b) {
  std::error_code ec;
  return std::filesystem::equivalent(a, b, ec);
}

// Loads the device descriptions the configuration asks for and checks that
// every device's model or EDS resolves to one: the part of validation the
// config layer cannot do (it links no device layer). Problems with files of a
// device directory that no device needs are warnings; the daemon skips them.
void load_catalog(const config::Config& cfg, device::DeviceCatalog& catalog, std::vector<std::string>& errors,
                  std::vector<std::string>& warnings) {
  for (const auto& dir : cfg.gateway.device_dirs) {
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec)) {
      warnings.push_back("device directory " + dir.string() + " does not exist");
      continue;
    }
    for (const auto& e : catalog.load_directory(dir)) warnings.push_back(e.to_string() + " (file skipped)");
  }
  for (const auto& d : cfg.devices) {
    if (d.eds.empty()) continue;
    const std::string who = "device \"" + d.name + "\": ";
    device::EdsResult r = device::load_eds_file(d.eds);
    if (!r.ok()) {
      errors.push_back(at(d.where, who + "eds file " + d.eds.string() + " is not a valid EDS (" +
                                       std::to_string(r.errors.size()) + " problem" +
                                       (r.errors.size() == 1 ? "" : "s") + ", listed below)"));
      std::stable_sort(r.errors.begin(), r.errors.end(),
                       [](const device::EdsError& a, const device::EdsError& b) { return a.line < b.line; });
      for (const auto& e : r.errors) errors.push_back(e.to_string());
      continue;
    }
    const auto& info = r.description->device_info;
    if (d.vendor && *d.vendor != info.vendor_number)
      errors.push_back(at(d.where, who + "vendor " + hex(*d.vendor) + " differs from the eds file's VendorNumber " +
                                       hex(info.vendor_number)));
    if (d.product && *d.product != info.product_number &&
        std::find(r.description->selection.additional_products.begin(),
                  r.description->selection.additional_products.end(),
                  *d.product) == r.description->selection.additional_products.end())
      errors.push_back(at(d.where, who + "product " + hex(*d.product) + " differs from the eds file's ProductNumber " +
                                       hex(info.product_number)));
    if (!device::family_profile_for(*r.description))
      errors.push_back(at(d.where, who + "eds file " + d.eds.string() + " names no device family cobridge knows "
                                       "([Cobridge] Family, see docs/devices.md)"));
    const auto all = catalog.all();
    const bool loaded = std::any_of(all.begin(), all.end(), [&](const device::DeviceDescription* x) {
      return same_file(x->source, d.eds);
    });
    // The same device may already be described by a directory's file; the
    // bus manager then selects by identity, which names the same device.
    if (!loaded) (void)catalog.load_file(d.eds);
  }
  for (const auto& d : cfg.devices) {
    if (d.model.empty()) continue;
    const config::KnownModel* km = config::find_model(d.model);
    if (km == nullptr) continue;  // the config loader has reported it
    const std::string variant = d.channels ? std::to_string(*d.channels) + "ch" : "";
    bool found = false;
    for (const auto* x : catalog.all()) {
      if (x->device_info.vendor_number != km->vendor || x->selection.family != family_name(km->family)) continue;
      if (!km->products.empty()) {
        const auto& extra = x->selection.additional_products;
        const bool product_ok =
            std::any_of(km->products.begin(), km->products.end(), [&](std::uint32_t p) {
              return p == x->device_info.product_number || std::find(extra.begin(), extra.end(), p) != extra.end();
            });
        if (!product_ok) continue;
      }
      if (!variant.empty() && !x->selection.variant.empty() && x->selection.variant != variant) continue;
      found = true;
      break;
    }
    if (!found) {
      std::string dirs;
      for (const auto& dir : cfg.gateway.device_dirs) dirs += (dirs.empty() ? "" : ", ") + dir.string();
      errors.push_back(at(d.where, "device \"" + d.name + "\": model " + d.model +
                                       " has no device description (an EDS with VendorNumber " + hex(km->vendor) +
                                       " and [Cobridge] Family=" + std::string(family_name(km->family)) +
                                       (variant.empty() ? "" : ", Variant=" + variant) + ") in " +
                                       (dirs.empty() ? "no device directory" : dirs)));
    }
  }
}

struct Validated {
  std::optional<config::Config> config;
  std::unique_ptr<device::DeviceCatalog> catalog;
  std::vector<std::string> errors;  // "file:line:column: message", in file order
  std::vector<std::string> warnings;
};

Validated validate(const std::filesystem::path& file) {
  Validated v;
  config::LoadResult r = config::load(file);
  if (!r) {
    for (const auto& d : r.diagnostics()) v.errors.push_back(config::to_string(d));
    return v;
  }
  v.catalog = std::make_unique<device::DeviceCatalog>();
  load_catalog(r.config(), *v.catalog, v.errors, v.warnings);
  if (v.errors.empty()) v.config = std::move(r).config();
  return v;
}

void print(const Validated& v, std::FILE* to) {
  for (const auto& w : v.warnings) std::fprintf(to, "warning: %s\n", w.c_str());
  for (const auto& e : v.errors) std::fprintf(to, "%s\n", e.c_str());
}

int check_config(const std::filesystem::path& file, const std::filesystem::path& plugin_dir) {
  Validated v = validate(file);
  if (v.config) {
    // What the daemon would refuse at start: an output it cannot load or
    // whose settings the plugin rejects.
    v.errors = gateway::check_outputs(*v.config, plugin_dir);
    if (v.config->web) {
      for (auto& e : web::check_web_settings(*v.config->web)) v.errors.push_back(std::move(e));
    }
    if (!v.errors.empty()) v.config.reset();
  }
  print(v, stderr);
  if (!v.config) {
    std::fprintf(stderr, "%s: %zu error%s\n", file.c_str(), v.errors.size(), v.errors.size() == 1 ? "" : "s");
    return 1;
  }
  std::printf("%s: ok (%zu bus%s, %zu device%s, %zu output%s, %zu device description%s%s)\n", file.c_str(),
              v.config->buses.size(), v.config->buses.size() == 1 ? "" : "es", v.config->devices.size(),
              v.config->devices.size() == 1 ? "" : "s", v.config->outputs.size(),
              v.config->outputs.size() == 1 ? "" : "s", v.catalog->size(), v.catalog->size() == 1 ? "" : "s",
              v.config->web && v.config->web->enabled ? ", web" : "");
  return 0;
}

// ---- running -----------------------------------------------------------------

void apply_logging(const config::LoggingSettings& logging, bool foreground) {
  sys::LogTarget target = sys::LogTarget::automatic;
  if (foreground || logging.target == config::LogTarget::console) target = sys::LogTarget::console;
  else if (logging.target == config::LogTarget::journal) target = sys::LogTarget::journal;
  sys::setup_logging(target, static_cast<spdlog::level::level_enum>(logging.level));
  for (const auto& [module, level] : logging.modules)
    sys::logger(module)->set_level(static_cast<spdlog::level::level_enum>(level));
}

// A reload keeps the buses open, so it may change what is on them, not which
// buses there are.
std::string bus_change(const config::Config& running, const config::Config& next) {
  if (running.buses.size() != next.buses.size()) return "the number of [[bus]] tables changed";
  for (std::size_t i = 0; i < running.buses.size(); ++i) {
    if (running.buses[i].name != next.buses[i].name || running.buses[i].interface != next.buses[i].interface)
      return "bus " + running.buses[i].name + " (" + running.buses[i].interface + ") became " + next.buses[i].name +
             " (" + next.buses[i].interface + ")";
  }
  return {};
}

// The plugins run with the settings they were created with: a reload that
// changes an output is refused rather than half applied.
std::string outputs_change(const config::Config& running, const config::Config& next) {
  if (running.outputs.size() != next.outputs.size()) return "the [outputs.*] tables changed";
  for (std::size_t i = 0; i < running.outputs.size(); ++i) {
    const auto& a = running.outputs[i];
    const auto& b = next.outputs[i];
    if (a.name != b.name || a.enabled != b.enabled || a.plugin != b.plugin || a.settings_toml != b.settings_toml)
      return "[outputs." + a.name + "] changed";
  }
  return {};
}

// The web service runs with the settings it was started with.
bool web_change(const config::Config& running, const config::Config& next) {
  const auto& a = running.web;
  const auto& b = next.web;
  if (a.has_value() != b.has_value()) return true;
  if (!a) return false;
  return a->enabled != b->enabled || a->bind != b->bind || a->port != b->port || a->tls_cert != b->tls_cert ||
         a->tls_key != b->tls_key || a->auth_file != b->auth_file || a->max_clients != b->max_clients ||
         a->timeout_s != b->timeout_s;
}

// What the control socket sees of the daemon.
class Daemon final : public gateway::ControlHandler {
 public:
  Daemon(const config::Config& cfg, std::vector<std::unique_ptr<gateway::BusManager>>& buses,
         const gateway::OutputPipeline& outputs)
      : config_(&cfg), buses_(buses), outputs_(outputs), started_(std::chrono::system_clock::now()) {}

  void set_config(const config::Config& cfg) {
    const std::lock_guard lock(mutex_);
    config_ = &cfg;
  }
  void set_ready() {
    const std::lock_guard lock(mutex_);
    ready_ = true;
  }

  // Main thread (control socket) and the web service's thread: the lock
  // keeps the configuration pointer and the ready flag consistent; the bus
  // managers and the output pipeline are safe to read from any thread.
  gateway::StatusReport status() override {
    const std::lock_guard lock(mutex_);
    gateway::StatusReport r;
    r.gateway_id = config_->gateway.id;
    r.version = COBRIDGE_VERSION;
    r.pid = static_cast<long>(::getpid());
    r.ready = ready_;
    r.started = started_;
    r.config_file = config_->source.string();
    const auto now = Clock::now();
    const auto wall = std::chrono::system_clock::now();
    for (std::size_t i = 0; i < buses_.size(); ++i) {
      gateway::BusStatus s = buses_[i]->status();
      outputs_.add_live_status(i, s, now, wall);
      r.buses.push_back(std::move(s));
    }
    r.outputs = outputs_.output_stats();
    return r;
  }

  gateway::ControlResult commission(std::string_view bus) override {
    const std::lock_guard lock(mutex_);
    gateway::ControlResult r;
    for (std::size_t i = 0; i < buses_.size(); ++i) {
      const auto& name = config_->buses[i].name;
      if (!bus.empty() && name != bus) continue;
      buses_[i]->request_commission();
      r.buses.push_back(name);
    }
    if (r.buses.empty()) {
      std::string names;
      for (const auto& b : config_->buses) names += (names.empty() ? "" : ", ") + b.name;
      return {false, "unknown bus \"" + std::string(bus) + "\" (buses: " + names + ")", {}};
    }
    sys::logger("gateway")->info("control socket: commissioning requested on {}", bus.empty() ? "every bus" : bus);
    return r;
  }

 private:
  const config::Config* config_;
  std::vector<std::unique_ptr<gateway::BusManager>>& buses_;
  const gateway::OutputPipeline& outputs_;
  std::chrono::system_clock::time_point started_;
  bool ready_ = false;
  std::mutex mutex_;
};

void stop_all(std::vector<std::unique_ptr<gateway::BusManager>>& buses) {
  // In parallel: each stop() may take up to 1 s, and SIGTERM must be done in 1 s.
  std::vector<std::thread> stoppers;
  for (auto& b : buses) stoppers.emplace_back([&b] { b->stop(); });
  for (auto& t : stoppers) t.join();
}

// The installed plugin directory (beside the executable), or the build tree's when running uninstalled.
std::filesystem::path default_plugin_dir() {
  return sys::installed_or(sys::InstallDir::plugins, COBRIDGE_BUILD_PLUGIN_DIR);
}

int run(const std::filesystem::path& config_file, bool foreground, const std::string& state_dir_override,
        const std::filesystem::path& plugin_dir) {
  // Before any thread: the bus managers inherit the blocked signal mask.
  sys::Signals signals;
  if (signals.error()) {
    std::fprintf(stderr, "cobridged: signals: %s\n", signals.error().message().c_str());
    return 1;
  }

  Validated v = validate(config_file);
  if (!v.config) {
    print(v, stderr);
    std::fprintf(stderr, "cobridged: %s: %zu error%s; no bus was touched\n", config_file.c_str(), v.errors.size(),
                 v.errors.size() == 1 ? "" : "s");
    return 1;
  }
  auto cfg = std::make_unique<config::Config>(std::move(*v.config));
  if (!state_dir_override.empty()) cfg->gateway.state_dir = state_dir_override;
  apply_logging(cfg->logging, foreground);
  auto log = sys::logger("gateway");
  for (const auto& w : v.warnings) log->warn("{}", w);
  const std::unique_ptr<device::DeviceCatalog> catalog = std::move(v.catalog);
  log->info("cobridged {} starting: {} ({} buses, {} devices, {} device descriptions)", COBRIDGE_VERSION,
            config_file.string(), cfg->buses.size(), cfg->devices.size(), catalog->size());

  sys::Notifier notifier;
  gateway::StateStore state(cfg->gateway.state_dir);
  std::string state_problems;
  if (const auto ec = state.load(&state_problems)) log->warn("state file {}: {}", state.path().string(), state_problems);

  std::vector<std::unique_ptr<gateway::BusManager>> buses;
  // Made here, started below once the control socket is ours; the control
  // socket's status reads its hot-path counters.
  gateway::OutputPipeline outputs(*cfg, *catalog, plugin_dir);
  Daemon daemon(*cfg, buses, outputs);

  // The control socket first: a second daemon started by mistake stops here,
  // before it touches a bus the first one serves.
  gateway::ControlServer control(daemon);
  std::string why;
  if (control.open(cfg->gateway.control_socket, &why)) {
    log->error("control socket: {}", why);
    return 1;
  }

  // The hot path and the output plugins start before the buses, so every
  // device's first configuration already reaches the decoders.
  bool outputs_fatal = false;
  const std::vector<std::string> output_problems = outputs.start(&outputs_fatal);
  for (const auto& p : output_problems) log->error("outputs: {}", p);
  if (outputs_fatal) {
    for (const auto& p : output_problems) std::fprintf(stderr, "%s\n", p.c_str());
    std::fprintf(stderr, "cobridged: %s: %zu output problem%s; no bus was touched\n", config_file.c_str(),
                 output_problems.size(), output_problems.size() == 1 ? "" : "s");
    return 1;
  }
  log->info("outputs: {} plugin{} running from {}", outputs.plugins_running(), outputs.plugins_running() == 1 ? "" : "s",
            plugin_dir.string());

  for (std::size_t i = 0; i < cfg->buses.size(); ++i) {
    gateway::BusManagerOptions options;
    options.observer = outputs.observer(i);
    buses.push_back(std::make_unique<gateway::BusManager>(*cfg, i, *catalog, state, options));
    outputs.set_command_target(i, buses.back().get());
  }
  for (std::size_t i = 0; i < buses.size(); ++i) {
    if (const auto ec = buses[i]->start()) {
      log->error("bus {} ({}): cannot start: {}", cfg->buses[i].name, cfg->buses[i].interface, ec.message());
      stop_all(buses);
      return 1;
    }
  }

  // The web service last: it reads the status of running buses. A daemon
  // told to serve it does not run without it (like an output).
  web::WebServer webserver([&daemon] { return daemon.status(); });
  if (cfg->web && cfg->web->enabled && !webserver.start(*cfg->web, &why)) {
    log->error("web: {}", why);
    std::fprintf(stderr, "cobridged: web: %s\n", why.c_str());
    stop_all(buses);
    outputs.stop();
    return 1;
  }

  bool ready = false;
  std::string last_status;
  std::string reload_note;  // appended to STATUS= while a rejected reload is the news
  const auto watchdog_period = std::chrono::duration_cast<Clock::duration>(notifier.watchdog_period());
  Clock::time_point next_watchdog = Clock::now();
  Clock::time_point next_tick = Clock::now();
  if (watchdog_period.count() > 0)
    log->info("systemd watchdog: pinging every {} ms while every bus is served",
              std::chrono::duration_cast<milliseconds>(watchdog_period).count());

  std::vector<pollfd> fds;
  while (true) {
    const auto now = Clock::now();
    auto deadline = std::min(next_tick, control.process(now));
    if (watchdog_period.count() > 0) deadline = std::min(deadline, next_watchdog);
    fds.clear();
    fds.push_back({signals.fd(), POLLIN, 0});
    control.add_poll_fds(fds);
    const auto wait = std::clamp(std::chrono::duration_cast<milliseconds>(deadline - now), milliseconds(0), kTick);
    ::poll(fds.data(), fds.size(), static_cast<int>(wait.count()) + (deadline > now ? 1 : 0));

    const sys::SignalAction action = signals.take();
    if (action == sys::SignalAction::stop) {
      const auto t0 = Clock::now();
      (void)notifier.stopping();
      log->info("stopping");
      webserver.stop();
      // The reverse of the start: no more plugin commands to the buses, the
      // buses (their last status and command outcomes still reach the hot
      // path), then the hot path and the plugins, then the control socket.
      for (std::size_t i = 0; i < buses.size(); ++i) outputs.set_command_target(i, nullptr);
      stop_all(buses);
      outputs.stop();
      control.close();
      log->info("stopped in {} ms", std::chrono::duration_cast<milliseconds>(Clock::now() - t0).count());
      return 0;
    }
    if (action == sys::SignalAction::reload) {
      (void)notifier.reloading();
      log->info("SIGHUP: reloading {}", config_file.string());
      Validated next = validate(config_file);
      std::string refusal;
      if (next.config) {
        if (!state_dir_override.empty()) next.config->gateway.state_dir = state_dir_override;
        refusal = bus_change(*cfg, *next.config);
        if (refusal.empty() && next.config->gateway.state_dir != cfg->gateway.state_dir)
          refusal = "gateway.state_dir changed";
        if (refusal.empty() && next.config->gateway.control_socket != cfg->gateway.control_socket)
          refusal = "gateway.control_socket changed";
        if (refusal.empty() && web_change(*cfg, *next.config)) refusal = "[web] changed";
        if (refusal.empty()) refusal = outputs_change(*cfg, *next.config);
        // Every layer takes the new configuration, or none does.
        if (refusal.empty()) refusal = outputs.reload(*next.config);
        if (!refusal.empty()) refusal += " (needs a restart)";
      }
      if (!next.config || !refusal.empty()) {
        for (const auto& e : next.errors) log->error("{}", e);
        if (!refusal.empty()) log->error("reload rejected: {}", refusal);
        log->error("reload rejected; still running the previous configuration");
        const std::size_t n = next.errors.size();
        reload_note = "; reload rejected (" +
                      (refusal.empty() ? std::to_string(n) + (n == 1 ? " config error" : " config errors") : refusal) +
                      ")";
      } else {
        for (const auto& w : next.warnings) log->warn("{}", w);
        // New description files are not picked up by a reload: the buses
        // keep the catalog they started with (a restart loads new ones).
        auto fresh = std::make_unique<config::Config>(std::move(*next.config));
        apply_logging(fresh->logging, foreground);
        for (auto& b : buses) b->reload(*fresh);
        daemon.set_config(*fresh);
        cfg = std::move(fresh);
        reload_note.clear();
        log->info("reloaded: {} devices", cfg->devices.size());
      }
      last_status.clear();  // tell STATUS= again after RELOADING
      // Before the first READY=1 the tick below still sends it.
      if (ready) (void)notifier.ready();
    }

    const auto after = Clock::now();
    if (after >= next_tick) {
      next_tick = after + kTick;
      if (!ready && std::all_of(buses.begin(), buses.end(), [](const auto& b) { return b->ready(); })) {
        ready = true;
        daemon.set_ready();
        (void)notifier.ready();
        log->info("ready");
      }
      std::vector<gateway::BusStatus> statuses;
      for (const auto& b : buses) statuses.push_back(b->status());
      const std::string text = gateway::summary(statuses) + reload_note;
      if (text != last_status) {
        (void)notifier.status(text);
        if (ready) log->info("{}", text);
        last_status = text;
      }
    }
    if (watchdog_period.count() > 0 && after >= next_watchdog) {
      next_watchdog = after + watchdog_period;
      // Every bus's control thread alive; an absent adapter is in STATUS=, not a reason to be restarted.
      if (std::all_of(buses.begin(), buses.end(), [](const auto& b) { return b->serving(); })) (void)notifier.watchdog();
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"cobridged: discovers, commissions, configures and supervises CANopen encoders on SocketCAN buses"};
  std::string config_file = "/etc/cobridge/cobridge.toml";
  std::string check_file;
  std::string state_dir;
  bool foreground = false;
  app.add_option("-c,--config", config_file, "configuration file")->capture_default_str();
  app.add_option("--check-config", check_file,
                 "validate FILE (and the device descriptions it needs), print every problem, exit 0 or 1; "
                 "never opens a bus");
  app.add_flag("-f,--foreground", foreground, "log to the console (the default when not under systemd)");
  app.add_option("--state-dir", state_dir, "override gateway.state_dir");
  std::string plugin_dir;
  app.add_option("--plugin-dir", plugin_dir, "where the output plugins are (default: the installed plugin directory)");
  app.set_version_flag("--version", std::string("cobridged ") + COBRIDGE_VERSION);
  CLI11_PARSE(app, argc, argv);

  const std::filesystem::path plugins = plugin_dir.empty() ? default_plugin_dir() : std::filesystem::path(plugin_dir);
  if (!check_file.empty()) return check_config(check_file, plugins);
  return run(config_file, foreground, state_dir, plugins);
}
