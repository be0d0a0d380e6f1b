// What the control socket and the web service see of the daemon: the status
// report (gateway id, version, readiness, every bus with its live hot-path
// figures) and the commissioning request (refused while the state file is
// held: no node-ID is assigned until an operator decides).
//
// Thread: status() from the main thread (control socket) and the web
// service's thread; commission() from the main thread. The lock keeps the
// configuration pointer and the ready flag consistent; the buses and the
// output pipeline are safe to read from any thread. set_config() and
// set_ready() on the main thread.
#pragma once

#include "app/bus_set.hpp"
#include "app/flight_recorders.hpp"
#include "config/config.hpp"
#include "control/control_server.hpp"
#include "bus/state_store.hpp"
#include "outputs/output_pipeline.hpp"

#include <chrono>
#include <mutex>
#include <string>
#include <string_view>

namespace cobridge::app {

class ControlFacade final : public control::ControlHandler {
 public:
  // `state`: the node-ID memory, whose hold refuses commissioning (may be null).
  ControlFacade(const config::Config& cfg, BusSet& buses, const outputs::OutputPipeline& outputs,
                std::string version, const FlightRecorders* recorders = nullptr,
                const bus::StateStore* state = nullptr);

  // After an accepted reload: `cfg` must outlive the next set_config().
  void set_config(const config::Config& cfg);
  void set_ready();

  control::StatusReport status() override;
  Result<std::vector<std::string>> commission(std::string_view bus) override;
  Result<std::vector<std::string>> capture_now(std::string_view bus) override;
  [[nodiscard]] Result<std::string> read_capture(std::string_view name) override;
  Result<std::vector<std::string>> acknowledge(std::string_view device, const std::string& caller) override;

 private:
  const config::Config* config_;
  BusSet& buses_;
  const outputs::OutputPipeline& outputs_;
  std::string version_;
  const FlightRecorders* recorders_;
  const bus::StateStore* state_;
  std::chrono::system_clock::time_point started_;
  bool ready_ = false;
  std::mutex mutex_;
};

}  // namespace cobridge::app
