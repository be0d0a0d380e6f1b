// cobridged's parts, built from the configuration, started in order and
// stopped in reverse:
//
//   signals        blocked before any thread starts (each thread inherits the mask)
//   configuration  validated with the device descriptions it needs
//   state store    the commissioned devices (state file)
//   control socket first to open: a second daemon stops here, before any bus
//   outputs        the plugins loaded (settings checked), then the hot path's
//                  receivers (their own threads)
//   buses          one BusManager each (its own control thread), while a
//                  helper thread starts the plugins; the dispatcher holds the
//                  samples until they run

//   web service    last, it reads the status of running buses (its own thread)
//
// The main thread runs serve(): it polls the signalfd and the control socket,
// reloads on SIGHUP and tells systemd what it should know (ServiceStatus).
//
// Thread: construct, start(), serve() and stop() on the main thread (start()
// waits for its helper thread before it returns).
#pragma once

#include "app/bus_set.hpp"
#include "app/control_facade.hpp"
#include "app/service_status.hpp"
#include "base/error.hpp"
#include "config/config.hpp"
#include "device/device_catalog.hpp"
#include "control/control_server.hpp"
#include "outputs/output_pipeline.hpp"
#include "bus/state_store.hpp"
#include "sys/bus_beacon.hpp"
#include "sys/notifier.hpp"
#include "sys/signals.hpp"
#include "web/web_server.hpp"

#include <filesystem>
#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace cobridge::app {

struct DaemonOptions {
  std::filesystem::path config_file;
  bool foreground = false;          // log to the console
  std::string state_dir_override;   // --state-dir, "" = the configuration's
  std::filesystem::path plugin_dir;
  std::string version;              // in the status report and the start line
};

class Daemon {
 public:
  explicit Daemon(DaemonOptions options);  // blocks the signals
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  // Builds and starts every part. On failure the reason has been logged (and
  // printed on stderr where an operator starting it by hand must see it),
  // what was started is stopped, and the error's kind gives the exit code.
  [[nodiscard]] Error start();
  // Until SIGTERM/SIGINT.
  void serve();
  // The reverse of start(); returns once every thread has ended.
  void stop();

 private:
  [[nodiscard]] Error load_configuration();
  [[nodiscard]] Error output_problems(std::vector<Error> problems, const char* aftermath);
  [[nodiscard]] std::vector<Error> start_plugins();  // a helper thread, while the buses start
  [[nodiscard]] Error start_web();
  void open_beacons();
  // The flight recorders into the receivers, their capture writers started.
  void start_recorders();
  void retry_beacons(std::chrono::steady_clock::time_point now);  // [redundancy]: take the peer's over
  void reload();
  [[nodiscard]] bool reload_state();

  DaemonOptions options_;
  sys::Signals signals_;
  std::unique_ptr<config::Config> cfg_;
  std::unique_ptr<device::DeviceCatalog> catalog_;
  std::optional<sys::Notifier> notifier_;
  std::optional<bus::StateStore> state_;
  bus::BusRegistry registry_;  // the buses clients' commands may reach; outlives them
  FlightRecorders recorders_;  // outlives the receivers and buses that use it
  BusSet buses_;
  std::optional<outputs::OutputPipeline> outputs_;
  std::optional<ControlFacade> facade_;
  std::optional<control::ControlServer> control_;
  std::vector<sys::BusBeacon> beacons_;  // one per bus, closed when another daemon holds it (sys/bus_beacon.hpp)
  std::chrono::steady_clock::time_point next_beacon_try_{};
  std::optional<web::WebServer> web_;
  std::optional<ServiceStatus> service_;
};

}  // namespace cobridge::app
